"""The recorded-data scenario plaza (pfbench.scenarios.plaza) and its data (pfbench.datasets), on
small Plaza-like .mat files written here (the real ones come with the extra, pip install
'.[data]', and are not in the repository), plus one test on the real data that skips without
them."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat
from typer.testing import CliRunner

from pfbench import datasets
from pfbench.cli import app
from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.filters.dead_reckoning import integrate
from pfbench.regen import check_config
from pfbench.rng import state_from_seed
from pfbench.scenarios import plaza
from pfbench.runner import LocalExecutor

from .conftest import one_line_exit_2, tree

SCALE, BIAS, NOISE = 1.07, 0.05, 0.1     # the synthetic ranges: z = SCALE d + BIAS + NOISE N(0, 1)
BEACON_IDS = (0, 1, 5, 6)


def _plaza_like(path: Path, seed: int, heading_off: float = 0.0, seconds: float = 120.0) -> None:
    """A Plaza-like .mat: a robot on a 20 m circle at 1 m/s sampled at 5 Hz (GT), its odometry
    (DR: each row turns, then moves, from GT[k] to GT[k+1]), 4 beacons (TL) and a range to one of
    them every 0.25 s (TD). ``heading_off``: added to GT's heading (Plaza 2's is pi off)."""
    rng = np.random.default_rng(seed)
    t = 100.0 + np.arange(0.0, seconds, 0.2)
    ang = t / 20.0                                   # 1 m/s on a 20 m circle
    x, y = 20.0 * np.cos(ang) - 5.0, 20.0 * np.sin(ang) + 3.0
    # the heading each row turns to before moving: the chord's direction
    chord = np.arctan2(np.diff(y), np.diff(x))
    th = np.concatenate([[chord[0]], chord])
    gt = np.column_stack([t, x, y, th + heading_off])
    dr = np.column_stack([t[1:], np.hypot(np.diff(x), np.diff(y)),
                          np.remainder(np.diff(th) + math.pi, 2 * math.pi) - math.pi])
    tl = np.array([[0, -30.0, -25.0], [1, 25.0, -20.0], [5, 20.0, 30.0], [6, -28.0, 28.0]])
    tt = np.arange(t[0] + 0.1, t[-1], 0.25)
    b = rng.integers(0, 4, tt.size)
    d = np.hypot(tl[b, 1] - np.interp(tt, t, x), tl[b, 2] - np.interp(tt, t, y))
    td = np.column_stack([tt, np.full(tt.size, 2.0), tl[b, 0],
                          SCALE * d + BIAS + NOISE * rng.standard_normal(tt.size)])
    savemat(path, {"GT": gt, "TL": tl, "DR": dr, "TD": td})


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("plaza")
    _plaza_like(folder / "Plaza1_.mat", 1)
    _plaza_like(folder / "Plaza2_.mat", 2, heading_off=math.pi)
    return folder


def _params(folder: Path, **over) -> dict:
    p = {k: v.default for k, v in plaza.SCHEMA.items()}
    p.update(data_dir=str(folder), verify_digest=False, range_noise_m=NOISE)
    p.update(over)
    return plaza.resolve(p, folder)


def test_calibration_recovers_the_scale_and_bias(data_dir):
    """fitted_on 'same' and 'other' both find SCALE and BIAS (the two files share them; the
    least-squares slope over ~480 ranges of sd 0.1 m has an sd of about 3e-4)."""
    for where in ("same", "other"):
        a, b = plaza.calibration(_params(data_dir, fitted_on=where))
        assert a == pytest.approx(SCALE, abs=3e-3) and b == pytest.approx(BIAS, abs=0.1)
    assert plaza.calibration(_params(data_dir, fitted_on="none")) == (1.0, 0.0)


@pytest.mark.parametrize("data", ["plaza1", "plaza2"])
def test_the_recorded_trial(data_dir, data):
    """The steps, the odometry and the heading fix: dead reckoning from the start follows the
    ground truth (the synthetic odometry is exact), the ranges are calibrated, and the time span
    cuts the steps."""
    model = plaza.build(_params(data_dir, data=data, fitted_on="same"))
    d, _ = plaza.simulate(model, None)
    assert d.pose.shape == (model.steps + 1, 3) and d.ctrl.shape == (model.steps, 3)
    assert model.steps == pytest.approx(120.0 / 0.2, abs=2)
    dr = integrate(model.start, d.ctrl)
    assert np.max(np.hypot(*(dr[:, :2] - d.pose[:, :2]).T)) < 1e-6
    assert np.max(np.abs(np.remainder(dr[:, 2] - d.pose[:, 2] + math.pi, 2 * math.pi)
                         - math.pi)) < 1e-6
    # the calibrated ranges against the true distances: residuals of the noise's size
    k, j = np.nonzero(np.arange(d.obs_id.shape[1]) < d.obs_n[:, None])
    true = np.hypot(*(model.beacons[d.obs_id[k, j]] - d.pose[k + 1, :2]).T)
    res = d.obs_z[k, j, 0] - true
    assert abs(np.mean(res)) < 0.05 and np.std(res) < 2.5 * NOISE     # 0.2 m of motion a step
    assert np.all((model.area > 0) & (d.pose[:, :2] > 0).all())
    short = plaza.build(_params(data_dir, data=data, start_s=10.0, end_s=40.0))
    assert short.steps == pytest.approx(150, abs=2)


def test_mcl_tracks_the_synthetic_set(data_dir):
    """MCL with 500 particles from the known start tracks the synthetic run (ranges of sd
    0.1 m): position RMSE over the last 100 steps under 0.5 m."""
    model = plaza.build(_params(data_dir, start="known"))
    d, _ = plaza.simulate(model, None)
    ft = FILTERS["mcl"]
    p = Params({k: v.default for k, v in ft.schema.items()})
    out = ft.run(model, d, p, 500, state_from_seed(np.random.SeedSequence(35)))
    err = np.hypot(*(out["pose"][:, :2] - d.pose[:, :2]).T)
    assert np.sqrt(np.mean(err[-100:] ** 2)) < 0.5


def test_digest_and_missing_data(data_dir, tmp_path, monkeypatch):
    """A file that is not the pinned one is refused (DataCorrupt); no installed extra and no
    data_dir is one line naming the extra; a data_dir without the file names the folder."""
    with pytest.raises(datasets.DataCorrupt, match="not the pinned file"):
        datasets.locate("plaza1", data_dir, verify=True)
    assert datasets.locate("plaza1", data_dir, verify=False) == data_dir / "Plaza1_.mat"
    assert datasets.sha256(data_dir / "Plaza1_.mat") != datasets.PLAZA_FILES["plaza1"][1]
    monkeypatch.setattr(datasets, "installed_file", lambda name: None)
    with pytest.raises(datasets.DataMissing, match=r"pip install '\.\[data\]'"):
        datasets.locate("plaza2")
    with pytest.raises(datasets.DataMissing, match="no Plaza1_.mat in"):
        datasets.locate("plaza1", tmp_path)
    assert plaza.unavailable({}) is not None
    assert plaza.unavailable({"data_dir": str(data_dir)}) is None


def test_installed_file_reads_the_distribution_without_importing(monkeypatch, tmp_path):
    """installed_file finds gtsam/Data/<name> through the distribution's RECORD (a fake
    installed distribution on sys.path), and gtsam is not imported."""
    import sys
    site = tmp_path / "site"
    (site / "gtsam" / "Data").mkdir(parents=True)
    (site / "gtsam" / "Data" / "Plaza2_.mat").write_bytes(b"x")
    info = site / "gtsam-4.3.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: gtsam\nVersion: 4.3.0\n")
    (info / "RECORD").write_text("gtsam/Data/Plaza2_.mat,,1\ngtsam-4.3.0.dist-info/METADATA,,\n")
    monkeypatch.syspath_prepend(str(site))
    assert datasets.installed_file("Plaza2_.mat") == site / "gtsam" / "Data" / "Plaza2_.mat"
    assert datasets.installed_file("Plaza1_.mat") is None
    assert "gtsam" not in sys.modules


def _config(tmp_path: Path, data_dir: str, **scen) -> Path:
    cfg = tmp_path / "plaza.yaml"
    extra = "".join(f"  {k}: {v}\n" for k, v in scen.items())
    cfg.write_text("description: plaza test\nseed: 1\ntrials: 2\ncheck:\n  trials: 2\n"
                   f"scenario:\n  name: plaza\n  data_dir: {data_dir}\n  verify_digest: false\n"
                   f"  end_s: 30.0\n{extra}filters:\n  dr:\n    type: dead_reckoning\n"
                   "  mcl:\n    particles: 100\n")
    return cfg


def test_absent_data_is_one_line_and_writes_nothing(tmp_path):
    """A run whose data are absent: exit 2, one line naming the folder, nothing written."""
    cfg = _config(tmp_path, "nowhere")
    before = tree(tmp_path)
    line = one_line_exit_2(CliRunner().invoke(app, ["run", str(cfg), "--out",
                                                    str(tmp_path / "out")]))
    assert "Plaza1_.mat" in line and "nowhere" in line
    assert tree(tmp_path) == before


def test_tables_check_skips_without_the_data_and_checks_with_them(tmp_path, data_dir):
    """tables --check's check of a plaza config: skipped, with the reason, when the data are
    absent; re-run and compared when they are there."""
    cfg = _config(tmp_path, str(data_dir))
    res = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "results" / "plaza"),
                                   "--no-figures"])
    assert res.exit_code == 0, res.output
    with LocalExecutor(1) as ex:
        r = check_config(cfg, tmp_path / "results", ex)
        assert not r.skipped and r.trials == 2 and r.compared > 0 and r.ok and r.identical
        gone = _config(tmp_path, str(tmp_path / "nowhere"))
        r = check_config(gone, tmp_path / "results", ex)
    assert r.skipped and "Plaza1_.mat" in r.skipped and r.ok and r.trials == 0


@pytest.mark.slow
def test_real_data_tracking_beats_dead_reckoning():
    """On the real Plaza 1, 300 s (with the extra installed; skipped without it): MCL with 1000
    particles, the range model cross-calibrated on Plaza 2, tracks with a position RMSE under
    1 m and under dead reckoning's, in each of 3 seeds."""
    why = plaza.unavailable({})
    if why is not None:
        pytest.skip(f"the Plaza data are not installed ({why})")
    p = plaza.resolve({k: v.default for k, v in plaza.SCHEMA.items()} | {"end_s": 300.0}, ".")
    model = plaza.build(p)
    d, _ = plaza.simulate(model, None)
    dr = np.sqrt(np.mean(np.sum((integrate(model.start, d.ctrl)[1:, :2] - d.pose[1:, :2]) ** 2,
                                axis=1)))
    ft = FILTERS["mcl"]
    params = Params({k: v.default for k, v in ft.schema.items()})
    for seed in range(3):
        out = ft.run(model, d, params, 1000, state_from_seed(np.random.SeedSequence(seed)))
        rmse = np.sqrt(np.mean(np.sum((out["pose"][1:, :2] - d.pose[1:, :2]) ** 2, axis=1)))
        assert rmse < min(1.0, dr), (seed, rmse, dr)
