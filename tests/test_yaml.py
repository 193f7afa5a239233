"""The bounded YAML reader: documents that would explode are refused at once; aliases, merge keys
and YAML 1.2 numbers still work."""
from __future__ import annotations

import time

import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
    for p, c in zip("abcdefgh", "bcdefghi"))


@pytest.mark.parametrize("text,words", [
    (BOMB + TINY, ["aliases", "expand"]),
    ("x: &r [1, *r]\n" + TINY, ["refers to a node that contains it"]),
    ("x: " + "[" * 5000 + "]" * 5000 + "\n" + TINY, ["nested deeper"]),
    ("x: " + "{a: " * 3000 + "1" + "}" * 3000 + "\n" + TINY, ["nested deeper"]),
    ("- " * 3000 + "1\n", ["nested deeper"]),
], ids=["alias bomb", "recursive alias", "deep list", "deep mapping", "deep block"])
def test_yaml_that_would_explode_is_refused_at_once(tmp_path, write_config, text, words):
    cfg = write_config(text)
    for cmd in (["run", str(cfg), "--out", str(tmp_path / "o")], ["validate", str(cfg)]):
        t0 = time.perf_counter()
        line = one_line_exit_2(runner.invoke(app, cmd))
        assert time.perf_counter() - t0 < 60
        for w in words:
            assert w in line, line
    assert not (tmp_path / "o").exists()


def test_a_few_aliases_and_merge_keys_still_work(write_config):
    exp = load(write_config(TINY.replace("  pf:\n    label: PF\n",
                                         "  pf: &base\n    label: PF\n")
                            + "  pf2:\n    <<: *base\n    type: pf\n    label: PF2\n"
                            "    particles: 10\n"))
    assert [f.key for f in exp.filters][-1] == "pf2@10"


def test_numbers_in_exponent_form_are_numbers(write_config):
    exp = load(write_config(TINY.replace("trials: 4", "trials: 1e1").replace(
        "process_noise_var: 1.0", "process_noise_var: 2e-1")))
    assert exp.trials == 10 and exp.scenario_params["process_noise_var"] == 0.2


def test_libyaml_and_the_pure_python_reader_give_the_same_data_and_lines():
    """Where PyYAML has libyaml, files are read with it: every committed config, paper and world
    file gives the same data and line numbers as the pure-Python loader; what libyaml refuses is
    read again by the pure-Python loader, whose message names the character."""
    import yaml

    from pfbench import yamlio
    from pfbench.schema import ConfigError

    from .conftest import ROOT
    if yamlio._FastLoader is None:
        pytest.skip("PyYAML without libyaml")
    files = sorted((ROOT / "configs").rglob("*.yaml"))
    assert len(files) > 15
    for path in files:
        text = path.read_text()
        fast = yamlio.parse_yaml(text, str(path))
        loader = yamlio._StrictLoader(text)
        node = loader.get_single_node()
        slow = (loader.construct_document(node), yamlio._lines(node))
        assert fast == slow, path
    with pytest.raises(ConfigError, match="found character '\\\\t' that cannot start any token"):
        yamlio.parse_yaml("a:\n\t- 1\n", "tabs.yaml")
    with pytest.raises(ConfigError, match="found undefined alias 'nope'"):
        yamlio.parse_yaml("a: *nope\n", "alias.yaml")
    assert yaml.__with_libyaml__
