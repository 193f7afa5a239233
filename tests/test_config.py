"""Every kind of bad config: exit status 2, one line naming the key, nothing written."""
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load
from pfbench.schema import ConfigError

from .conftest import SMALL

runner = CliRunner()


def _run_bad(tmp_path, write_config, text, *extra):
    cfg = write_config(text)
    out = tmp_path / "results"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), *extra])
    assert res.exit_code == 2, res.output
    lines = [l for l in res.output.strip().splitlines() if l.strip()]
    assert len(lines) == 1, res.output
    assert "Traceback" not in res.output
    assert not out.exists()
    return lines[0]


CASES = [
    # (description, replace this, with that, words the message must contain)
    ("duplicate key", "  steps: 30\n", "  steps: 30\n  steps: 40\n", ["steps", "duplicate key", ":6", "first given on line 5"]),
    ("unknown top key", "seed: 0\n", "seed: 0\nseeed: 1\n", ["seeed", "did you mean 'seed'"]),
    ("unknown nested key", "    label: PF\n", "    label: PF\n    resampleing: systematic\n",
     ["filters.pf.resampleing", "did you mean 'resampling'"]),
    ("unknown scenario key", "  steps: 30\n", "  steps: 30\n  stepz: 3\n", ["scenario.stepz"]),
    ("quoted number is text", "trials: 6\n", "trials: '6'\n", ["trials", "string '6'",
                                                                "write it unquoted"]),
    ("bool is not an int", "trials: 6\n", "trials: true\n", ["trials", "boolean true"]),
    ("float is not an int", "steps: 30\n", "steps: 30.5\n", ["scenario.steps", "integer"]),
    ("particles >= 2", "particles: [20, 40]", "particles: [20, 1]", ["filters.pf.particles[1]", ">= 2"]),
    ("variance > 0", "process_noise_var: 1.0", "process_noise_var: 0.0",
     ["scenario.process_noise_var", "> 0"]),
    ("negative variance", "process_noise_var: 1.0", "process_noise_var: -1.0",
     ["scenario.process_noise_var"]),
    ("not finite", "process_noise_var: 1.0", "process_noise_var: .inf",
     ["scenario.process_noise_var", "finite"]),
    ("nan", "process_noise_var: 1.0", "process_noise_var: .nan", ["process_noise_var", "finite"]),
    ("unknown scenario", "name: ungm", "name: ungn", ["scenario.name", "did you mean 'ungm'",
                                                     "linear_gaussian"]),
    ("unknown filter type", "  ukf:\n    label: UKF\n", "  ukff:\n    label: UKF\n",
     ["filters.ukff", "did you mean 'ukf'", "valid types"]),
    ("unknown resampling", "    label: PF\n", "    label: PF\n    resampling: sistematic\n",
     ["filters.pf.resampling", "did you mean 'systematic'", "residual"]),
    ("particles on a ukf", "    label: UKF\n", "    label: UKF\n    particles: 10\n",
     ["filters.ukf.particles", "no particles"]),
    ("missing particles", "    particles: [20, 40]\n", "", ["filters.pf.particles", "missing"]),
    ("seed negative", "seed: 0", "seed: -1", ["seed", ">= 0"]),
    ("duplicate particle counts", "[20, 40]", "[20, 20]", ["filters.pf.particles", "distinct"]),
    ("bad yaml", "filters:\n", "filters: [\n", ["not valid YAML"]),
    ("kappa too small", "    label: UKF\n", "    label: UKF\n    kappa: -5.0\n", ["filters.ukf.kappa"]),
    ("unknown paper", "seed: 0\n", "seed: 0\npaper: ifa2012\n", ["paper", "did you mean 'ifa2021'"]),
    ("unknown baseline", "seed: 0\n", "seed: 0\ncompare: {baseline: pff}\n",
     ["compare.baseline", "did you mean 'pf'"]),
    ("paper_runs moved", "seed: 0\n", "seed: 0\ncompare: {paper_runs: 100}\n",
     ["compare.paper_runs", "the table's 'runs' in the paper file"]),
    ("rel_tol moved", "seed: 0\n", "seed: 0\ncompare: {rel_tol: 0.1}\n",
     ["compare.rel_tol", "a margin of the quantity in the paper file"]),
    ("negative floor", "    label: PF\n", "    label: PF\n    likelihood_floor: -1.0\n",
     ["filters.pf.likelihood_floor", ">= 0"]),
]


@pytest.mark.parametrize("name,old,new,words", CASES, ids=[c[0] for c in CASES])
def test_bad_config_is_one_line_exit_2(tmp_path, write_config, name, old, new, words):
    assert old in SMALL
    line = _run_bad(tmp_path, write_config, SMALL.replace(old, new, 1))
    assert line.startswith("pfbench: error: ")
    assert "exp.yaml" in line
    for w in words:
        assert w in line, (w, line)


def test_validate_reports_the_same_errors(tmp_path, write_config):
    cfg = write_config(SMALL.replace("trials: 6", "trials: 0"))
    res = runner.invoke(app, ["validate", str(cfg)])
    assert res.exit_code == 2 and "trials" in res.output


def test_missing_file(tmp_path):
    res = runner.invoke(app, ["run", str(tmp_path / "nope.yaml")])
    assert res.exit_code == 2 and "no such file" in res.output


def test_set_override_bad_path_and_good_path(tmp_path, write_config):
    cfg = write_config(SMALL)
    line = _run_bad(tmp_path, write_config, SMALL, "--set", "filters.pff.particles=5")
    assert "filters.pff" in line and "did you mean 'pf'" in line
    exp = load(cfg, sets=["filters.*.label=X", "scenario.steps=12", "filters.pf.particles=[3, 4]"])
    assert exp.scenario_params["steps"] == 12
    assert [f.key for f in exp.filters] == ["pf@3", "pf@4", "ukf"]
    assert {f.label for f in exp.filters} == {"X"}


def test_debug_shows_the_traceback(tmp_path, write_config):
    cfg = write_config(SMALL.replace("trials: 6", "trials: 0"))
    res = runner.invoke(app, ["--debug", "validate", str(cfg)])
    assert res.exit_code != 0 and res.exception is not None


def test_cli_flags_override_the_file(write_config):
    exp = load(write_config(SMALL), {"trials": 3, "seed": 7})
    assert (exp.trials, exp.seed) == (3, 7)


def test_label_and_particles_must_be_unique(tmp_path, write_config):
    text = SMALL + "  pf2:\n    type: pf\n    label: PF\n    particles: 40\n"
    line = _run_bad(tmp_path, write_config, text)
    assert "label 'PF'" in line


def test_shipped_configs_validate():
    from .conftest import ROOT
    paths = sorted((ROOT / "configs").glob("*.yaml"))
    assert paths
    # the issues' minimums: 500 trials for the UNGM and Gamma tables, the paper's 20 for FastSLAM
    minimum = {"ifa_pf_ungm": 500, "sspf_upf_gamma": 500, "sspf_ungm": 500, "ifa_fastslam": 20}
    from pfbench.config import read_yaml
    from pfbench.sweep import expand
    for p in paths:
        raw, _ = read_yaml(p)
        exps = [c.exp for c in expand(p, {}, {})[1]] if "sweep" in raw else [load(p)]
        for exp in exps:
            # every config compares with a paper, but a recorded data set's (plaza): it is the
            # data's evaluation, with no paper's values to judge (docs/guide/real-data.md)
            assert exp.paper is not None or exp.scenario == "plaza", p
            assert exp.trials >= minimum.get(p.stem, 5 if exp.scenario == "plaza" else 20), p
            assert all(f.label for f in exp.filters)


def test_yaml_merge_keys_share_settings_and_explicit_keys_override(write_config):
    cfg = write_config("trials: 2\nscenario: {name: ungm, steps: 10}\nfilters:\n"
                       "  pf: &base\n    particles: 30\n    resampling: stratified\n"
                       "  pf_sys:\n    <<: *base\n    type: pf\n    resampling: systematic\n")
    exp = load(cfg)
    a, b = exp.filters
    assert (a.particles, a.params["resampling"]) == (30, "stratified")
    assert (b.particles, b.params["resampling"]) == (30, "systematic")
    dup = write_config("trials: 2\nscenario: {name: ungm, steps: 10}\nfilters:\n"
                       "  pf: &base\n    particles: 30\n"
                       "  pf2:\n    <<: *base\n    type: pf\n    type: pf\n", name="dup.yaml")
    with pytest.raises(ConfigError, match="duplicate key"):
        load(dup)
