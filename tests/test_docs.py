"""The README and the docs site say what the code does: the generated pages are those the code
and the committed results give, the README is a front page with the two set-up commands, every
`pfbench` command the docs show exists with its options, and the examples validate."""
import importlib.util
import re
import shutil
import subprocess
import sys

import pytest

from .conftest import ROOT

DOCS = ROOT / "docs"


def _pages() -> list:
    return sorted(DOCS.rglob("*.md"))


def _script(tmp_path):
    """scripts/update_readme.py as a module, pointed at a copy of README.md and docs/."""
    spec = importlib.util.spec_from_file_location("update_readme_copy",
                                                  ROOT / "scripts/update_readme.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")
    shutil.copytree(DOCS, tmp_path / "docs")
    mod.README, mod.DOCS = tmp_path / "README.md", tmp_path / "docs"
    mod.ROOT = tmp_path
    return mod


def test_generated_docs_match_the_code_and_the_results():
    res = subprocess.run([sys.executable, str(ROOT / "scripts/update_readme.py"), "--check"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


@pytest.mark.parametrize("page, edit", [
    ("docs/reference/config.md", ("| `seed` |", "| `seed_` |")),       # a block's line
    ("docs/reference/cli.md", ("## `pfbench run`", "## `pfbench runs`")),  # a whole page
    ("docs/reference/api.md", ("pfbench.load_results", "pfbench.load")),
    ("docs/internals/speed.md", ("| normal draws |", "| normal |")),
    ("docs/papers/ifa2021.md", ("| `scenario.prior_var` |", "| `scenario.prior` |")),
    ("README.md", ("| ifa2021 | Table 1 |", "| ifa2021 | Table 9 |")),
])
def test_the_check_finds_any_generated_text_edited_by_hand_and_write_restores_it(
        tmp_path, capsys, page, edit):
    mod = _script(tmp_path)
    path = tmp_path / page
    text = path.read_text()
    assert edit[0] in text
    path.write_text(text.replace(edit[0], edit[1], 1))
    assert mod.main(["--check"]) == 1
    assert page in capsys.readouterr().err
    assert mod.main(["--write"]) == 0
    assert path.read_text() == text
    assert mod.main(["--check"]) == 0


def test_a_generated_block_that_vanishes_or_loses_its_end_is_an_error(tmp_path):
    mod = _script(tmp_path)
    page = tmp_path / "docs/reference/config.md"
    text = page.read_text()
    page.write_text(text.replace("<!-- config-keys:end -->", ""))
    with pytest.raises(SystemExit, match="config-keys block has no end marker"):
        mod.main(["--check"])
    page.write_text(re.sub(r"<!-- config-keys:begin -->.*<!-- config-keys:end -->", "", text,
                           flags=re.S))
    with pytest.raises(SystemExit, match="no page holds the generated block.*config-keys"):
        mod.main(["--check"])
    page.write_text(text.replace("config-keys:", "config-kyes:"))
    with pytest.raises(SystemExit, match="unknown generated block 'config-kyes'"):
        mod.main(["--check"])


def test_generated_prose_never_reads_as_html(tmp_path):
    mod = _script(tmp_path)
    assert mod._esc("the folder results/<name> or `results/<name>`") == (
        "the folder results/&lt;name&gt; or `results/<name>`")
    keys = (DOCS / "reference/config.md").read_text()
    assert "results/&lt;name&gt;" in keys
    for page in ("reference/config.md", "reference/cli.md", "reference/api.md"):
        prose = re.sub(r"`[^`]*`", "", (DOCS / page).read_text())
        prose = re.sub(r"```.*?```|<!--.*?-->", "", prose, flags=re.S)
        assert not re.search(r"<[A-Za-z/]", prose), page


def test_the_reference_covers_every_key_command_option_and_api_name():
    """Generated, so nothing is left out: every schema key, every command and option of the
    typer app, every public name of the API, every module of the package."""
    import typer

    import pfbench
    from pfbench.cli import app
    from pfbench.config import TOP_SCHEMA
    from pfbench.filters import FILTERS
    from pfbench.scenarios import SCENARIOS
    keys = (DOCS / "reference/config.md").read_text()
    for name in TOP_SCHEMA:
        assert f"| `{name}` |" in keys
    for ftype in FILTERS.values():
        for name in ftype.schema:
            assert f"| `{name}` |" in keys, (ftype.name, name)
    for mod in SCENARIOS.values():
        for name in mod.SCHEMA:
            assert f"| `scenario.{name}` |" in keys
    cli = (DOCS / "reference/cli.md").read_text()
    group = typer.main.get_command(app)
    for name, cmd in group.commands.items():
        section = cli.split(f"## `pfbench {name}`\n", 1)[1].split("\n## ", 1)[0]
        for p in cmd.params:
            if p.param_type_name == "option" and not p.hidden:
                assert all(o in section for o in p.opts), (name, p.opts)
    api = (DOCS / "reference/api.md").read_text()
    for name in pfbench.__all__:
        assert f"pfbench.{name}" in api
    arch = (DOCS / "internals/architecture.md").read_text()
    for path in (ROOT / "pfbench").rglob("*.py"):
        assert f"`{path.relative_to(ROOT).as_posix()}`" in arch


def test_the_readme_is_a_front_page_with_exactly_the_two_setup_commands():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    assert "pip install . && pfbench run configs/ifa_fastslam.yaml" in text
    assert 'pip install ".[test]" && pytest' in text
    setup = text.split("## Set-up", 1)[1].split("\n## ", 1)[0]
    commands = [line for line in setup.splitlines() if line.startswith("    ")]
    assert len(commands) == 2
    # every relative link of the README resolves in the checkout (as on GitHub)
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    assert any(link.startswith("docs/") for link in links)
    missing = [link for link in links if "://" not in link and not (ROOT / link).exists()]
    assert not missing, missing


def test_the_docs_experiment_files_validate(tmp_path, monkeypatch):
    """The experiment file of 'Experiment files' and every config of the tutorial."""
    from pfbench.config import load
    monkeypatch.chdir(ROOT)                 # their paper is found in configs/papers/
    text = (DOCS / "guide/experiment-files.md").read_text()
    block = re.search(r"```yaml\n(.*?)```", text, re.S).group(1)
    cfg = tmp_path / "example.yaml"
    cfg.write_text(block)
    exp = load(cfg)
    assert exp.reported is not None and exp.compare["floor"] == "pf_floor@5000"
    n = 0
    for page in sorted((DOCS / "tutorial").glob("*.md")):
        for block in re.findall(r"```yaml\n(.*?)```", page.read_text(), re.S):
            cfg = tmp_path / f"tutorial{n}.yaml"
            cfg.write_text(block)
            if "type: my_pf" in block:      # the tutorial's own plug-in, not installed here
                cfg.write_text(block.replace("type: my_pf", "type: pf"))
            assert load(cfg).filters, page
            n += 1
    assert n >= 2


# a command as code: in backticks or quotes, or at the head of an indented code line
_TAIL = r"pfbench ([a-z][a-z-]*)((?:[ \t]+[^\s`'\"]+)*)"
_PROSE = re.compile(r"(?:(?<=`)|(?<=')|(?<=^    )|(?<=^       )|(?<=\$ ))" + _TAIL, re.M)
_SOURCE = re.compile(r"(?:(?<=`)|(?<='))" + _TAIL)
_FENCE = re.compile(r"^```(?:bash|sh|shell|console|text)?\n(.*?)^```", re.S | re.M)
_LINE = re.compile(r"^[ \t]*(?:\$ )?" + _TAIL, re.M)


def _commands(text: str, markdown: bool):
    if not markdown:
        yield from _SOURCE.finditer(text)
        return
    yield from _PROSE.finditer(text)
    for fence in _FENCE.finditer(text):
        yield from _LINE.finditer(fence.group(1))


def test_every_pfbench_command_and_option_the_docs_name_exists():
    """Each `pfbench COMMAND --option` in the README, in the docs pages (in code, in a command
    block) and in pfbench's docstrings is a command of the CLI with that option (a doc once named
    a `pfbench list --keys` that did not exist)."""
    import typer

    from pfbench.cli import app
    group = typer.main.get_command(app)
    opts = {name: {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
            for name, cmd in group.commands.items()}
    texts = [(p, True) for p in [ROOT / "README.md", *_pages()]]
    texts += [(p, False) for p in sorted((ROOT / "pfbench").rglob("*.py"))]
    bad, seen = [], 0
    for path, markdown in texts:
        for m in _commands(path.read_text(), markdown):
            seen += 1
            cmd, rest = m.group(1), m.group(2)
            if cmd not in opts:
                bad.append(f"{path.name}: {m.group(0)}")
                continue
            for o in re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", rest):
                if o not in opts[cmd] and o != "--help":
                    bad.append(f"{path.name}: {m.group(0)} ({o})")
    assert seen > 100
    assert not bad, bad


def test_the_command_check_sees_commands_in_command_blocks():
    fake = "text\n\n```bash\npfbench runn configs/x.yaml\n$ pfbench run x --nope\n```\n"
    found = {f"pfbench {m.group(1)}{m.group(2)}" for m in _commands(fake, True)}
    assert found == {"pfbench runn configs/x.yaml", "pfbench run x --nope"}


@pytest.mark.slow
def test_the_first_run_the_readme_and_tutorial_show_is_what_the_command_prints(tmp_path):
    """The README's first command prints the table the README shows (the trials are seeded:
    the same numbers on every machine; the run-time ratios of the 'time / PF' table below it are
    this machine's, and left out)."""
    from typer.testing import CliRunner

    from pfbench.cli import app
    text = (ROOT / "README.md").read_text()
    command = re.search(r"^    (pfbench run configs/ifa_pf_ungm\.yaml .*)$", text, re.M).group(1)
    args = command.split()[1:]
    args[args.index("--out") + 1] = str(tmp_path / "first")
    shown = re.search(r"```text\n(.*?)```", text.split("## A first experiment", 1)[1],
                      re.S).group(1)
    rmse = shown.split("\ntime / PF", 1)[0]
    rows = [line.rstrip() for line in rmse.splitlines() if "│" in line]
    assert len(rows) > 20
    assert shown in (DOCS / "tutorial/first-run.md").read_text()
    res = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    printed = {line.rstrip() for line in res.output.splitlines()}
    assert [r for r in rows if r not in printed] == []
