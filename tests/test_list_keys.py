"""``pfbench list --keys NAME``: every filter type's and scenario's keys (plug-ins too) with
their kinds, defaults, bounds and docs; an unknown name is one line naming the close ones. And
``schema.Key``: its docstring names the command and every kind, and a kind it does not know is
refused where the key is declared."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib

import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.schema import KEY_KINDS, REQUIRED, ConfigError, Key

from .conftest import ROOT, one_line_exit_2

runner = CliRunner()


def _key_lines_ok(text: str, schema: dict) -> None:
    """Each key of ``schema`` is printed with its kind, default, what it accepts and its doc."""
    lines = text.splitlines()
    for name, key in schema.items():
        head = next((i for i, l in enumerate(lines)
                     if l.startswith(f"  {name} ({key.kind}, default {key.default_text()}): ")),
                    None)
        assert head is not None, (name, text)
        assert key.expected() in lines[head]
        assert lines[head + 1].strip() == " ".join(key.doc.split())


def test_every_filter_and_scenario_prints_its_keys():
    from pfbench.filters import FILTERS
    from pfbench.protocols import FILTER_COMMON
    from pfbench.scenarios import SCENARIOS
    for name, f in FILTERS.items():
        res = runner.invoke(app, ["list", "--keys", name])
        assert res.exit_code == 0, res.output
        assert res.output.startswith(f"filter type {name}")
        assert f"runs on {f.kind} scenarios" in res.output
        _key_lines_ok(res.output, FILTER_COMMON)
        _key_lines_ok(res.output, f.schema)
        assert "configs (" not in res.output            # the keys, not the lists
    for name, mod in SCENARIOS.items():
        res = runner.invoke(app, ["list", "--keys", name])
        assert res.exit_code == 0, res.output
        assert f"scenario {name}" in res.output and f"kind {mod.KIND}" in res.output
        _key_lines_ok(res.output, mod.SCHEMA)


def test_bounds_defaults_and_choices_are_shown():
    res = runner.invoke(app, ["list", "--keys", "pf"])
    assert "  neff_ratio (float, default 0.5): a number > 0 and <= 1" in res.output
    assert "  resampling (choice, default systematic): one of 'multinomial'" in res.output
    assert "  particles (ints, default null): an integer or a list of integers >= 2, or null" \
        in res.output
    res = runner.invoke(app, ["list", "--keys", "beacon_field"])
    assert "  kidnap_steps (ints, default []): " in res.output
    assert "  range_outliers (float, default 0): a number >= 0 and < 1" in res.output
    assert "  alphas (floats, default [0.0014, 0.000125, 0.01, 0.26]): " in res.output


@pytest.mark.parametrize("name, close", [("pff", "'pf'"), ("ungn", "'ungm'"), ("Ekf", "'ekf'"),
                                         ("beacon-field", "'beacon_field'")])
def test_an_unknown_name_is_one_line_with_the_close_names(name, close):
    line = one_line_exit_2(runner.invoke(app, ["list", "--keys", name]))
    assert f"--keys '{name}': no filter type or scenario of that name" in line
    assert close in line


@pytest.mark.parametrize("name", ["zzzzzz", "", "[bold]x[/bold]", "ü" * 300])
def test_a_name_like_nothing_lists_every_name(name):
    line = one_line_exit_2(runner.invoke(app, ["list", "--keys", name]))
    assert "filters: pf, " in line and "scenarios: ungm, " in line


def test_keys_and_check_do_not_combine():
    line = one_line_exit_2(runner.invoke(app, ["list", "--keys", "pf", "--check"]))
    assert "--keys" in line and "--check" in line


def test_keys_without_a_name_is_one_line():
    res = runner.invoke(app, ["list", "--keys"])
    assert res.exit_code == 2 and "Traceback" not in res.output


def test_a_plugins_keys_and_a_plugin_left_out(tmp_path):
    """A plug-in's filter and scenario print their keys; a plug-in that failed to load is named
    with why, in one line."""
    site = tmp_path / "site"
    example = ROOT / "tests" / "plugin_example"
    shutil.copytree(example / "pfbench_example", site / "pfbench_example")
    eps = tomllib.loads((example / "pyproject.toml").read_text())["project"]["entry-points"]
    text = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in items.items())
                   for group, items in eps.items())
    text += "[pfbench.filters]\nbadkind = badkind_mod:F\nkernpf = kern_mod:F\n"
    info = site / "pfbench_example-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pfbench-example\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(text)
    (site / "badkind_mod.py").write_text(
        "from pfbench.filters import FilterType\nfrom pfbench.schema import Key\n"
        "F = FilterType('badkind', 'x', {'n': Key('integer', 1, 'a count')}, lambda *a: {})\n")
    (site / "kern_mod.py").write_text(      # a plug-in of the kernel API, found by discovery
        "from pfbench.kernels import STATE, normal, resample\n"
        "from pfbench.filters import FilterType\nfrom pfbench.schema import Key\n"
        "F = FilterType('kernpf', 'x', {'n': Key('int', 2, 'a count', min=1)}, "
        "lambda *a: {})\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(ROOT)]), COLUMNS="200")

    def pfbench(*args):
        return subprocess.run([sys.executable, "-m", "pfbench.cli", *args], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=600)

    got = pfbench("list", "--keys", "metropolis_pf")
    assert got.returncode == 0, got.stderr
    assert "filter type metropolis_pf (plug-in: pfbench-example)" in got.stdout
    assert "  iterations (int, default 20): an integer >= 1" in got.stdout
    got = pfbench("list", "--keys", "bearings_road")
    assert got.returncode == 0, got.stderr
    assert "scenario bearings_road (plug-in: pfbench-example)" in got.stdout
    assert "  dt_s (float, default 1): a number > 0" in got.stdout
    got = pfbench("list", "--keys", "kernpf")
    assert got.returncode == 0, got.stderr
    assert "  n (int, default 2): an integer >= 1" in got.stdout
    got = pfbench("list", "--keys", "badkind")
    assert got.returncode == 2 and got.stdout == ""
    lines = got.stderr.strip().splitlines()
    assert len(lines) == 1 and "badkind" in lines[0] and "'integer'" in lines[0], got.stderr
    assert "did you mean 'int'" in lines[0]


def test_keys_docstring_names_the_command_and_every_kind():
    doc = Key.__doc__
    assert "pfbench list --keys NAME" in doc
    for kind in KEY_KINDS:
        assert f"- '{kind}': " in doc, kind


# a value each kind accepts, one it refuses
SAMPLES = {"int": (3, "3"), "float": (2.5, "x"), "str": ("a", ""), "bool": (True, 1),
           "choice": ("a", "c"), "ints": ([1, 2], [1, 1]), "floats": ([0.5, 1], ["x"]),
           "names": (["a"], ["c"])}


@pytest.mark.parametrize("kind", sorted(KEY_KINDS))
def test_every_kind_listed_validates(kind):
    """KEY_KINDS is what validate knows: each kind accepts a value and refuses another, and says
    what it expects."""
    assert set(SAMPLES) == set(KEY_KINDS)
    key = Key(kind, REQUIRED, "doc", choices=("a", "b"), words=("all",))
    good, bad = SAMPLES[kind]
    key.validate("k", good)
    with pytest.raises(ConfigError):
        key.validate("k", bad)
    assert key.expected()


def test_an_unknown_kind_is_refused_where_it_is_declared():
    with pytest.raises(ValueError, match=r"'integer' is none of .*did you mean 'int'"):
        Key("integer", 1, "a count")


def test_a_bound_may_exclude_its_maximum():
    """``max_exclusive``: the bound itself is refused, below it accepted, and the expected
    values say '< max' (an outlier probability of 1 would leave no true measurement)."""
    key = Key("float", 0.0, "a probability", min=0.0, max=1.0, max_exclusive=True)
    assert key.expected() == "a number >= 0 and < 1"
    assert key._range_ok(0.999) and key._range_ok(0.0)
    assert not key._range_ok(1.0) and not key._range_ok(1.5)
    closed = Key("float", 0.0, "a probability", min=0.0, max=1.0)
    assert closed._range_ok(1.0) and closed.expected() == "a number >= 0 and <= 1"
