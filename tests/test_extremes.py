"""Every filter survives extreme valid settings (two particles, vanishing or huge noise) with
finite numbers, and a lost localization filter is counted as diverged."""
from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app

runner = CliRunner()


def _scalar_filters():
    """Every filter type that runs on ungm (what the tests below configure)."""
    from pfbench.filters import FILTERS
    return [n for n, f in FILTERS.items() if f.runs_on("ungm", "scalar")]


@pytest.mark.parametrize("particles,noise", [(2, 1.0), (2, 1e-9), (50, 1e-4), (3, 1e6)])
def test_every_scalar_filter_survives_extreme_valid_settings(tmp_path, write_config, particles,
                                                              noise):
    from pfbench.filters import FILTERS
    lines = []
    for name in _scalar_filters():
        n = f"    particles: {particles}\n" if FILTERS[name].particles else ""
        lines.append(f"  {name}:\n    type: {name}\n{n}")
    cfg = write_config("seed: 3\ntrials: 3\nscenario:\n  name: ungm\n  steps: 40\n"
                       f"  measurement_noise_var: {noise!r}\nfilters:\n" + "".join(lines))
    res = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o"), "--no-figures"])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "o/trials.csv")
    assert set(df["filter"].str.split("@").str[0]) == set(_scalar_filters())
    # an estimate that is not a number is counted, never silent
    bad = df[~df["rmse"].map(lambda v: v == v and abs(v) != float("inf"))]
    assert (bad["diverged_steps"] > 0).all(), bad


FIELD_TINY = """\
seed: 1
trials: 3
scenario:
  name: beacon_field
  steps: 30
  range_noise_m: 1.0e-9
filters:
  mcl:
    particles: 2
  sspf:
    particles: 2
"""


def test_localization_filters_with_two_particles_and_no_sensor_noise(tmp_path):
    import shutil
    root = Path(__file__).resolve().parents[1]
    shutil.copytree(root / "configs" / "worlds", tmp_path / "worlds")
    (tmp_path / "exp.yaml").write_text(FIELD_TINY)
    res = runner.invoke(app, ["run", str(tmp_path / "exp.yaml"), "--out", str(tmp_path / "o"),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "o/trials.csv")
    # an estimate far outside the 40 m field is a divergence event, not a silent error
    far = df[df["final_error"] > 100]
    assert (far["diverged_steps"] > 0).all(), far
    # two particles lose the robot: the steps outside the world are counted and named
    assert df["diverged_steps"].sum() > 0
    note = next(l for l in (tmp_path / "o/table.md").read_text().splitlines()
                if "left the world" in l)
    assert "trial" in note


def test_an_estimate_outside_the_world_is_counted_as_diverged():
    import numpy as np

    from pfbench.metrics import localization_metrics
    T = 5
    pose = np.zeros((T + 1, 3)) + [10.0, 10.0, 0.0]
    est = pose.copy()
    est[2, 0] = 6.6e5
    est[4, 1] = -1.0
    est[5, 0] = np.nan
    out = {"pose": est, "ess": np.ones(T), "resampled": np.zeros(T), "lik_evals_per_step": 1.0}
    row = localization_metrics(pose, out, 0.5, np.array([], dtype=np.int64), area=[40.0, 40.0])
    assert row["diverged_steps"] == 3.0
    out["pose"] = pose.copy()
    assert localization_metrics(pose, out, 0.5, np.array([], dtype=np.int64),
                                area=[40.0, 40.0])["diverged_steps"] == 0.0
