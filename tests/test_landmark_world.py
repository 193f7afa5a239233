"""The afsa2014 landmark world: odometry motion, noise reading, FastSLAM in it."""
import math

import numpy as np
import pytest

from pfbench.angles import wrap
from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.rng import state_from_seed
from pfbench.scenarios import landmark_world as lw

from .conftest import ROOT


def _model(**over):
    p = {k: v.default for k, v in lw.SCHEMA.items()}
    p.update(over)
    return lw.build(lw.resolve(p, ROOT / "configs"))


def test_without_process_noise_the_truth_integrates_the_odometry():
    model = _model(steps=900, process_noise_xy_m=0.0, process_noise_heading_deg=0.0)
    truth, data = lw.simulate(model, state_from_seed(np.random.SeedSequence(0)))
    x, y, th = model.start
    for t, (ds, dth) in enumerate(data.ctrl):
        th = th + dth
        x, y = x + ds * math.cos(th), y + ds * math.sin(th)
        assert truth.pose[t + 1] == pytest.approx([x, y, wrap(th)], abs=1e-9)
    assert np.all(np.abs(data.ctrl[:, 0] - 0.3 * 0.5) < 1e-12)        # 0.3 m/s x 0.5 s
    assert np.max(np.abs(data.ctrl[:, 1])) <= math.radians(20) * 0.5 + 1e-12
    assert data.obs_n.min() >= 2


def test_noise_values_read_as_variances_on_request():
    std = _model()
    var = _model(noise_values="variance")
    assert std.noise[0] == 0.01 and var.noise[0] == pytest.approx(0.1)
    assert var.noise[3] == pytest.approx(math.sqrt(0.1) * math.pi / 180)


def test_fastslam_follows_the_truth_without_noise_in_the_landmark_world():
    model = _model(steps=600, process_noise_xy_m=0.0, process_noise_heading_deg=0.0,
                   range_noise_m=1e-9, bearing_noise_deg=1e-9)
    truth, data = lw.simulate(model, state_from_seed(np.random.SeedSequence(1)))
    ft = FILTERS["fastslam"]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(predict_noise=False)
    out = ft.run(model, data, Params(p), 5, state_from_seed(np.random.SeedSequence(2)))
    assert np.max(np.abs(out["pose"] - truth.pose)) < 1e-9


def test_fastslam_with_its_pose_noise_tracks_the_landmark_world():
    model = _model(steps=800)
    truth, data = lw.simulate(model, state_from_seed(np.random.SeedSequence(3)))
    ft = FILTERS["fastslam"]
    p = Params({k: v.default for k, v in ft.schema.items()})
    out = ft.run(model, data, p, 20, state_from_seed(np.random.SeedSequence(4)))
    err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
    assert err.max() < 1.0
