"""Files of a results folder that are not regular files (a FIFO would make a reader wait for ever
for a writer; /dev/zero never ends) are refused in one line, by every reader."""
import os
import subprocess
import sys
import textwrap

import pytest

from tests.conftest import TINY

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")

NAMES, HOWS = ("trials.csv", "meta.json"), ("fifo", "dev-zero")

# one child process for every case (a reader that waited for ever would meet the timeout): one
# run, then for each case a copy of its folder with that file replaced, read by each reader
SCRIPT = textwrap.dedent("""
    import os, shutil, sys
    from pathlib import Path
    import pfbench
    from pfbench.errors import UserError
    cfg, base = sys.argv[1:3]
    pfbench.run_experiment(cfg, out=base, figures=False)
    for case in sys.argv[3:]:
        name, how = case.split(":")
        out = f"{base}-{name}-{how}"
        shutil.copytree(base, out)
        target = Path(out) / name
        target.unlink()
        if how == "fifo":
            os.mkfifo(target)
        else:
            os.symlink("/dev/zero", target)
        for call in (lambda: pfbench.load_results(out),
                     lambda: pfbench.run_experiment(cfg, out=out, figures=False)):
            try:
                call()
            except UserError as exc:
                print(case, "refused:", exc, flush=True)
            else:
                print(case, "accepted", flush=True)
""")


@pytest.fixture(scope="module")
def readers(tmp_path_factory):
    """case 'name:how' -> the lines the two readers gave for the folder with ``name`` replaced
    by a FIFO or a link to /dev/zero."""
    tmp = tmp_path_factory.mktemp("kinds")
    cfg = tmp / "exp.yaml"
    cfg.write_text(TINY)
    cases = [f"{name}:{how}" for name in NAMES for how in HOWS]
    res = subprocess.run([sys.executable, "-c", SCRIPT, str(cfg), str(tmp / "out"), *cases],
                         capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stderr
    said: dict[str, list[str]] = {case: [] for case in cases}
    for line in res.stdout.strip().splitlines():
        case, _, rest = line.partition(" ")
        said[case].append(rest)
    return said


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("how", HOWS)
def test_a_results_file_that_is_a_fifo_or_a_device_is_refused_at_once(readers, name, how):
    lines = readers[f"{name}:{how}"]
    assert len(lines) == 2, lines
    for line in lines:
        assert line.startswith("refused:"), lines
        assert name in line and ("FIFO" in line or "device" in line), line
