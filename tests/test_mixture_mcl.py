"""Mixture MCL on the beacon field: the dual sampler, the density weights, phi = 0 as plain MCL,
recovery from a kidnapping, determinism, the key rules."""
import math

import numpy as np
import pytest

from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.filters import mixture_mcl as mx
from pfbench.filters.mcl import MclOptions
from pfbench.rng import state_from_seed
from pfbench.scenarios import beacon_field as bf

from .conftest import ROOT


def _field(**over):
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(over)
    return bf.build(bf.resolve(p, ROOT / "configs"))


def _run(name, model, data, N, seed=0, **over):
    ft = FILTERS[name]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    return ft.run(model, data, Params(p), N, state_from_seed(np.random.SeedSequence(seed)))


def _opts(sensor, sr=0.3, sb=0.05, N=4000):
    return MclOptions(motion=0, sensor=sensor, sr=sr, sb=sb, N=N, threshold=math.inf, scheme=1,
                      reset=0, inject_sensor=0, kld=0)


@pytest.mark.parametrize("sensor", [0, 1])
def test_dual_samples_are_consistent_with_the_measurement(sensor):
    """Every dual pose lies on the range circle of one of the step's observations (its range to
    that beacon within 5 sd of the measured range) and, with bearings, sees that beacon at the
    measured bearing within 5 sd; about phi of the particles are dual."""
    area = np.array([40.0, 40.0])
    bc = np.array([[10.0, 12.0], [30.0, 25.0], [5.0, 35.0]])
    ids = np.array([1, 0])
    zs = np.array([[7.5, 0.4], [12.0, -1.1]])
    o, N, phi = _opts(sensor), 4000, 0.25
    dw = mx.new_dual_work(N, bc.shape[0])
    s = state_from_seed(np.random.SeedSequence(3))
    k = mx.dual_draws(N, area, bc, 2, ids, zs, o, phi, dw, s)
    # binomial(4000, 0.25): sd 27.4; 5 sd
    assert abs(k - phi * N) < 5 * math.sqrt(N * phi * (1 - phi))
    assert dw.dual.sum() == k and np.all(dw.dual[dw.didx[:k]] == 1)
    seen = set()
    for r in range(k):
        j = dw.dobs[r]
        seen.add(int(j))
        b = ids[j]
        x, y, th = dw.D[:, r]
        rng = math.hypot(bc[b, 0] - x, bc[b, 1] - y)
        assert abs(rng - zs[j, 0]) < 5 * o.sr
        if sensor == 1:
            brg = math.atan2(bc[b, 1] - y, bc[b, 0] - x) - th
            assert abs(math.remainder(brg - zs[j, 1], 2 * math.pi)) < 5 * o.sb
    assert seen == {0, 1}


def test_kde_weights_by_hand():
    """Two particles, Gaussian kernels of bandwidth 1 m and 1 rad: the density at a pose is the
    mean of the two kernels, computed here in plain arithmetic."""
    P = np.array([[0.0, 2.0], [0.0, 0.0], [0.0, 0.5]])
    D = np.array([[1.0, 0.0], [0.0, 3.0], [0.0, 3.0]])
    out, E = np.empty(2), np.empty(2)
    mx.kde_logdensity(P, 2, D, 2, 1.0, 1.0, E, out)

    def kernel(dx, dy, dh):
        return (math.exp(-0.5 * (dx * dx + dy * dy)) / (2 * math.pi)
                * math.exp(-0.5 * dh * dh) / math.sqrt(2 * math.pi))
    # pose (1, 0, 0): 1 m from both particles; headings 0 and 0.5 rad off
    want0 = 0.5 * (kernel(1, 0, 0) + kernel(1, 0, 0.5))
    # pose (0, 3, 3): heading 3 rad against 0 and 0.5 (differences 3 and 2.5 rad, no wrap)
    want1 = 0.5 * (kernel(0, 3, 3) + kernel(2, 3, 2.5))
    assert out[0] == pytest.approx(math.log(want0), rel=1e-12)
    assert out[1] == pytest.approx(math.log(want1), rel=1e-12)
    # a heading difference past pi wraps: 3 against -3 is 0.283 rad apart
    mx.kde_logdensity(np.array([[0.0], [0.0], [-3.0]]), 1, np.array([[0.0], [0.0], [3.0]]), 1,
                      1.0, 1.0, E, out)
    assert out[0] == pytest.approx(math.log(kernel(0, 0, 2 * math.pi - 6)), rel=1e-12)


def test_histogram_weights_by_hand():
    """Cells of 1 m x 1 m x 90 deg: three of four particles share a cell; the density there is
    3 / (4 * 1 * 1 * pi/2), elsewhere 1 / (4 * pi/2), in an empty cell zero (log -inf)."""
    P = np.array([[0.2, 0.7, 0.9, 5.5], [0.1, 0.4, 0.9, 5.5], [0.1, 0.2, 1.0, 0.1]])
    D = np.array([[0.5, 5.1, 2.5], [0.5, 5.9, 2.5], [0.5, 0.3, 0.5]])
    out = np.empty(3)
    mx.histogram_logdensity(P, 4, D, 3, 1.0, math.pi / 2, np.array([10.0, 10.0]), np.empty(4), out)
    assert out[0] == pytest.approx(math.log(3 / (4 * math.pi / 2)))
    assert out[1] == pytest.approx(math.log(1 / (4 * math.pi / 2)))
    assert out[2] == -math.inf


def test_separate_weights_give_each_set_its_share():
    """combine: separate: the dual set's weights sum to k / (N - k) of the MCL set's, and each
    set's weights keep their ratios."""
    N, k = 6, 2
    dw = mx.new_dual_work(N, 1)
    dw.dual[:] = [0, 1, 0, 0, 1, 0]
    dw.didx[:k] = [1, 4]
    dw.logd[:k] = [math.log(3.0), math.log(1.0)]
    ll = np.log(np.array([1.0, 99.0, 2.0, 3.0, 99.0, 4.0]))
    W = np.empty(N)
    mp = mx.MixtureParams(0.3, 0, 1.0, 1.0, 0, 0)
    assert mx.mixture_weights(ll, W, N, k, dw, mp) == 0
    m, d = W[dw.dual == 0], W[dw.dual == 1]
    assert d.sum() / m.sum() == pytest.approx(k / (N - k))
    assert m / m[0] == pytest.approx([1, 2, 3, 4]) and d[0] / d[1] == pytest.approx(3.0)


def test_phi_zero_is_plain_mcl_draw_for_draw():
    model = _field(sensor="range_bearing", motion="rot_trans_rot", field_of_view_deg=180.0,
                   steps=60, initial="known", kidnap_steps=[30])
    _, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(3)))
    for scheme in ("systematic", "multinomial"):
        a = _run("mcl", model, data, 300, seed=1, resampling=scheme)
        b = _run("mixture_mcl", model, data, 300, seed=1, phi=0.0, resampling=scheme)
        for key in ("pose", "ess", "pmean"):
            assert np.array_equal(a[key], b[key]), key
        assert b["injected"].sum() == 0


def test_deterministic_and_the_seed_matters():
    model = _field(sensor="range", steps=40)
    _, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(5)))
    for kw in ({}, {"density": "histogram"}, {"dual_weight": "importance", "combine": "joint"}):
        a = _run("mixture_mcl", model, data, 200, seed=2, **kw)
        b = _run("mixture_mcl", model, data, 200, seed=2, **kw)
        c = _run("mixture_mcl", model, data, 200, seed=3, **kw)
        assert np.array_equal(a["pose"], b["pose"]) and np.array_equal(a["injected"], b["injected"])
        assert not np.array_equal(a["pose"], c["pose"])
        assert a["injected"].sum() > 0


def test_recovers_from_a_kidnapping_more_often_than_mcl():
    """30 kidnapped trials (known start, kidnapped at step 30 to a fixed far pose, 40 steps after
    it): plain MCL's particles all stay where the robot was, so it almost never recovers; Mixture
    MCL's dual samples find the robot. Recovered: the error below 1 m for the last 10 steps.
    The difference in recovered trials must be at least 10 of 30 (a binomial test of the
    paired counts would call 10 of 30 discordant pairs, all one way, significant far beyond
    the 1e-3 level)."""
    model = _field(sensor="range_bearing", motion="rot_trans_rot", field_of_view_deg=180.0,
                   steps=70, initial="known", kidnap_steps=[30], kidnap_poses=[34.0, 30.0, 180.0])
    rec = {"mcl": 0, "mixture_mcl": 0}
    for trial in range(30):
        _, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(400 + trial)))
        for name in rec:
            out = _run(name, model, data, 500, seed=trial)
            err = np.hypot(*(out["pose"][-10:, :2] - data.pose[-10:, :2]).T)
            rec[name] += bool(np.all(err < 1.0))
    assert rec["mixture_mcl"] - rec["mcl"] >= 10, rec


def test_joint_needs_importance_weights():
    ft = FILTERS["mixture_mcl"]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(combine="joint")
    key, msg = ft.check(p)
    assert key == "combine" and "importance" in msg
    p.update(dual_weight="importance")
    assert ft.check(p) is None
