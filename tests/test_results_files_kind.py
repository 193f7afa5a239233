"""Files of a results folder that are not regular files (a FIFO would make a reader wait for ever
for a writer; /dev/zero never ends) are refused in one line, by every reader."""
import os
import subprocess
import sys
import textwrap

import pytest

from tests.conftest import TINY

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")

SCRIPT = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    import pfbench
    from pfbench.errors import UserError
    cfg, out, name, how = sys.argv[1:5]
    pfbench.run_experiment(cfg, out=out, figures=False)
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
            print("refused:", exc)
        else:
            print("accepted")
""")


@pytest.mark.parametrize("name", ["trials.csv", "meta.json"])
@pytest.mark.parametrize("how", ["fifo", "dev-zero"])
def test_a_results_file_that_is_a_fifo_or_a_device_is_refused_at_once(tmp_path, name, how):
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(TINY)
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-c", SCRIPT, str(cfg), str(out), name, how],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.strip().splitlines()
    assert len(lines) == 2, res.stdout
    for line in lines:
        assert line.startswith("refused:"), res.stdout
        assert name in line and ("FIFO" in line or "device" in line), line
