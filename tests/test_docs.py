import subprocess
import sys

from .conftest import ROOT


def test_readme_keys_and_example_match_the_schemas_and_results():
    res = subprocess.run([sys.executable, str(ROOT / "scripts/update_readme.py"), "--check"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


def test_readme_has_exactly_the_two_setup_commands():
    text = (ROOT / "README.md").read_text()
    assert "pip install . && pfbench run configs/ifa_pf_ungm.yaml" in text
    assert 'pip install ".[test]" && pytest' in text
