import subprocess
import sys

from .conftest import ROOT


def test_readme_keys_and_example_match_the_schemas_and_results():
    res = subprocess.run([sys.executable, str(ROOT / "scripts/update_readme.py"), "--check"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


def test_readme_has_exactly_the_two_setup_commands():
    text = (ROOT / "README.md").read_text()
    assert "pip install . && pfbench run configs/ifa_fastslam.yaml" in text
    assert 'pip install ".[test]" && pytest' in text


def test_the_readmes_experiment_file_validates(tmp_path, monkeypatch):
    import re

    from pfbench.config import load
    text = (ROOT / "README.md").read_text()
    section = text.split("## Experiment files", 1)[1]
    block = re.search(r"```yaml\n(.*?)```", section, re.S).group(1)
    cfg = tmp_path / "example.yaml"
    cfg.write_text(block)
    monkeypatch.chdir(ROOT)                 # its paper is found in configs/papers/
    exp = load(cfg)
    assert exp.reported is not None and exp.compare["floor"] == "pf_floor@5000"
