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


def test_every_pfbench_command_and_option_the_docs_name_exists():
    """Each `pfbench COMMAND --option` in the README and in pfbench's docstrings is a command of
    the CLI with that option (a doc once named a `pfbench list --keys` that did not exist)."""
    import re

    import typer

    from pfbench.cli import app
    group = typer.main.get_command(app)
    opts = {name: {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
            for name, cmd in group.commands.items()}
    texts = [(ROOT / "README.md").read_text()]
    texts += [p.read_text() for p in sorted((ROOT / "pfbench").rglob("*.py"))]
    bad = []
    # a command as code: in backticks or quotes, or at the head of an indented code line
    tail = r"pfbench ([a-z][a-z-]*)((?:[ \t]+[^\s`'\"]+)*)"
    readme = re.compile(r"(?:(?<=`)|(?<=')|(?<=^    )|(?<=^       )|(?<=\$ ))" + tail, re.M)
    source = re.compile(r"(?:(?<=`)|(?<='))" + tail)
    for i, text in enumerate(texts):
        for m in (readme if i == 0 else source).finditer(text):
            cmd, rest = m.group(1), m.group(2)
            if cmd not in opts:
                bad.append(m.group(0))
                continue
            for o in re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", rest):
                if o not in opts[cmd] and o != "--help":
                    bad.append(f"{m.group(0)} ({o})")
    assert not bad, bad
