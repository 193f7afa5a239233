"""The plug-in guide is enough on its own: its package, taken from the code blocks of the guide's
section "A model with its own likelihood" (docs/how-to/plugins.md) and nothing else, is built and
installed by pip (not editable, into a folder of its own), and pfbench, started from a folder with
no repository in it, validates and runs the guide's experiment on it and keeps the contract with
it (every filter that runs on the new scenario, the trap suite included).

Slow (pip builds a wheel, pfbench compiles the plug-in's kernels): CI runs it with ``-m slow``."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "how-to" / "plugins.md"
SECTION = "## A model with its own likelihood\n"


def guide_blocks() -> dict[str, str]:
    """The fenced code blocks of the guide's section, by language (toml, python, yaml): each
    appears once, as the guide's reader copies it."""
    text = GUIDE.read_text(encoding="utf-8")
    assert SECTION in text, f"{GUIDE} has no section {SECTION.strip()!r}"
    section = text.split(SECTION, 1)[1].split("\n## ", 1)[0]
    found = re.findall(r"```(\w+)\n(.*?)```", section, re.DOTALL)
    langs = [lang for lang, _ in found]
    assert sorted(langs) == ["python", "toml", "yaml"], langs
    return dict(found)


def write_package(folder: Path, blocks: dict[str, str]) -> tuple[Path, str]:
    """The guide's package in ``folder`` (pyproject.toml and the module it names): its path and
    the scenario's name (the entry point the guide registers)."""
    project = tomllib.loads(blocks["toml"])
    (scenario, target), = project["project"]["entry-points"]["pfbench.scenarios"].items()
    module = target.split(":")[0]
    folder.mkdir(parents=True)
    (folder / "pyproject.toml").write_text(blocks["toml"], encoding="utf-8")
    (folder / f"{module}.py").write_text(blocks["python"], encoding="utf-8")
    return folder, scenario


def test_the_guide_names_one_package_one_module_and_an_experiment_on_its_scenario():
    """What the slow test builds is what the guide shows: its pyproject registers one scenario,
    the module it names is the guide's Python block, and the experiment uses that scenario."""
    import yaml
    blocks = guide_blocks()
    project = tomllib.loads(blocks["toml"])
    scenarios = project["project"]["entry-points"]["pfbench.scenarios"]
    assert len(scenarios) == 1
    (name, target), = scenarios.items()
    assert target.split(":")[0] in project["tool"]["setuptools"]["py-modules"]
    assert f'NAME = "{name}"' in blocks["python"]
    assert yaml.safe_load(blocks["yaml"])["scenario"]["name"] == name


@pytest.mark.slow
def test_the_guides_plugin_installed_by_pip_validates_runs_and_keeps_the_contract(tmp_path):
    blocks = guide_blocks()
    package, scenario = write_package(tmp_path / "package", blocks)
    site = tmp_path / "site"
    # not editable: a wheel built from the package's files, installed into a folder of its own
    # (pfbench and numba, its dependencies, are this environment's)
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                          "--target", str(site), str(package)],
                         capture_output=True, text=True, timeout=900)
    assert pip.returncode == 0, pip.stdout + pip.stderr
    assert not any(site.glob("*.egg-link")) and not any(site.glob("__editable__*"))
    assert list(site.glob("*.dist-info/entry_points.txt"))

    work = tmp_path / "work"            # no configs/, no repository: what a pip user has
    work.mkdir()
    cfg = work / f"{scenario}.yaml"
    cfg.write_text(blocks["yaml"].replace("trials: 20", "trials: 4"), encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=str(site), COLUMNS="200")

    def pfbench(*args):
        return subprocess.run([sys.executable, "-m", "pfbench.cli", *args], cwd=work, env=env,
                              capture_output=True, text=True, timeout=1200)

    listed = pfbench("list")
    assert listed.returncode == 0, listed.stderr
    assert any(line.split()[:1] == [scenario] for line in listed.stdout.splitlines())

    valid = pfbench("validate", cfg.name)
    assert valid.returncode == 0, valid.stdout + valid.stderr

    out = work / "out"
    run = pfbench("run", cfg.name, "--out", str(out), "--no-figures")
    assert run.returncode == 0, run.stdout + run.stderr
    table = pd.read_csv(out / "table.csv")
    assert len(table) == 3 and table["rmse_mean"].notna().all()

    # the filters that assume a Gaussian measurement are refused on it, in one line, before
    # anything is written
    refused = work / "ukf.yaml"
    refused.write_text(f"seed: 1\ntrials: 2\nscenario:\n  name: {scenario}\nfilters:\n  ukf: {{}}\n",
                       encoding="utf-8")
    res = pfbench("run", refused.name, "--out", str(work / "refused"))
    assert res.returncode == 2, res.stdout + res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "gaussian" in res.stderr.lower()
    assert not (work / "refused").exists()

    check = pfbench("check", "--only", scenario)
    assert check.returncode == 0, check.stdout + check.stderr
    assert "all kept" in check.stderr, check.stderr
    assert sorted(p.name for p in work.iterdir()) == ["out", cfg.name, "ukf.yaml"]
