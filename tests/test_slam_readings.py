"""The readings of the robot papers' open choices as keys: FastSLAM's refinement (the random
step's unit, IFA's brightness of a pose), directional resampling's variants (afsa2014) and SRL's
count of sensor draws (Lenser and Veloso against pfbench's fixed fraction). Each on a small
hand-checked case and end to end on a tiny run; the defaults are covered by the existing tests
and ``pfbench tables --check``."""
import math

import numpy as np
import pytest

from pfbench.config import Params, load
from pfbench.filters import FILTERS
from pfbench.filters import fastslam as fs
from pfbench.filters.mcl import ResetParams, srl_resets
from pfbench.filters.swarm import new_swarm_work, swarm_params
from pfbench.rng import state_from_seed
from pfbench.runner import run_experiment
from pfbench.scenarios import beacon_field as bf
from pfbench.scenarios import waypoint_course as wc

from .conftest import ROOT


def _params(name, **over):
    p = {k: v.default for k, v in FILTERS[name].schema.items()}
    p.update(over)
    return Params(p)


def _course(**over):
    p = {k: v.default for k, v in wc.SCHEMA.items()}
    p.update(over)
    return wc.build(wc.resolve(p, ROOT / "configs"))


def _field(**over):
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(over)
    return bf.build(bf.resolve(p, ROOT / "configs"))


def _state(seed):
    return state_from_seed(np.random.SeedSequence(seed))


# --- SRL's count -------------------------------------------------------------------------------

def _rp(rule, fraction=0.1, threshold=0.01):
    return ResetParams(fraction, threshold, 1.0, 1.0, 0.0, 0.0, float(rule))


@pytest.mark.parametrize("pm,fixed,lenser", [
    (0.004, 10, 60),        # 100 (1 - 0.4) = 60; a tenth of 100 = 10
    (0.0099, 10, 1),        # 100 (1 - 0.99) = 1
    (0.0, 10, 100),         # nothing likely: every particle is drawn from the sensor
    (0.01, 0, 0),           # at the threshold: no reset (strictly below it)
    (0.5, 0, 0),
    (math.nan, 0, 0)])
def test_srl_counts_by_each_rule(pm, fixed, lenser):
    assert srl_resets(100, pm, _rp(0)) == fixed
    assert srl_resets(100, pm, _rp(1)) == lenser


def test_lenser_veloso_count_ignores_the_fraction():
    # N = 37, p_mean a quarter of the threshold: 37 * 3/4 = 27.75 -> 28, whatever srl_fraction
    for fraction in (0.0, 0.1, 1.0):
        assert srl_resets(37, 0.25, _rp(1, fraction, 1.0)) == 28


def test_lenser_veloso_resets_as_many_as_the_formula_in_a_run():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=60,
                   kidnap_steps=[40], kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, _state(21))
    thr = 0.05
    out = FILTERS["mcl"].run(model, data, _params("mcl", reset="srl", srl_rule="lenser_veloso",
                                                 srl_threshold=thr), 500, _state(0))
    pm = out["pmean"]
    want = np.where((pm < thr) & (data.obs_n > 0), np.round(500 * (1.0 - pm / thr)), 0)
    assert np.array_equal(out["injected"], want.astype(np.int64))
    assert out["injected"][39] > 250         # the kidnapping: most of the set is drawn anew
    fixed = FILTERS["mcl"].run(model, data, _params("mcl", reset="srl", srl_threshold=thr), 500,
                               _state(0))
    assert set(np.unique(fixed["injected"])) <= {0, 50}


# --- FastSLAM's refinement ---------------------------------------------------------------------

def _refine_case(N=12, seed=3, **over):
    """A predicted cloud of N poses with one mapped landmark each, observed once: the arguments
    of ``refine_poses`` under the keys ``over``."""
    model = _course()
    params = _params("fastslam", **over)
    o = fs.options(model, params, N, False)
    ps = fs.new_particles(N, 2, np.zeros(3))
    rng = np.random.default_rng(seed)
    ps.P[:] = rng.normal(scale=[0.4, 0.3, 0.05], size=(N, 3)) + [10.0, 5.0, 0.3]
    ps.seen[:, 0] = 1
    ps.mu[:, 0] = [20.0, 9.0]
    ps.sig[:, 0] = [0.1, 0.0, 0.1]
    ids = np.array([0], dtype=np.int64)
    zs = np.array([[math.hypot(10.0, 4.0), math.atan2(4.0, 10.0) - 0.3]])
    sp = swarm_params(params["refine"], params)
    return ps, np.zeros((N, 6)), ids, zs, 1, o, sp, new_swarm_work(N, 3)


def test_fixed_step_unit_scales_the_random_term_per_coordinate():
    """FA without attraction (beta0 = 0) moves each firefly only by its random terms,
    alpha unit_d (u - 0.5) per brighter firefly: the same draws give displacements in the ratio
    of the units, fixed metres and radians against the cloud's spread."""
    over = dict(refine="fa", beta0=0.0, alpha=1.0)
    moved = {}
    for unit in ("cloud_spread", "fixed"):
        case = _refine_case(step_unit=unit, step_unit_m=0.5, step_unit_rad=0.1, **over)
        ps = case[0]
        P0 = ps.P.copy()
        fs.refine_poses(*case, _state(9))
        moved[unit] = ps.P - P0
        if unit == "cloud_spread":
            spread = P0.std(axis=0)
    fixed = moved["fixed"] / [0.5, 0.5, 0.1]
    cloud = moved["cloud_spread"] / spread
    assert np.allclose(fixed, cloud, rtol=1e-9, atol=1e-12)
    # the dimmest of 12 takes 11 kicks of at most half a unit; the brightest none
    assert np.all(np.abs(moved["fixed"]).max(axis=0) <= 11 * 0.5 * np.array([0.5, 0.5, 0.1]))
    assert (np.abs(moved["fixed"]).sum(axis=1) == 0.0).sum() == 1


def test_fixed_step_unit_is_the_afsa_visual_range_in_metres():
    """AFSA's moves in fixed units: a fish moves at most 'step' units per behaviour."""
    case = _refine_case(refine="afsa", step=0.2, visual=1.0, step_unit="fixed", step_unit_m=0.5,
                        step_unit_rad=0.01)
    ps = case[0]
    P0 = ps.P.copy()
    fs.refine_poses(*case, _state(4))
    d = (ps.P - P0) / [0.5, 0.5, 0.01]
    assert np.sqrt((d ** 2).sum(axis=1)).max() <= 0.2 + 1e-9
    assert np.abs(d).max() > 0.0


@pytest.mark.parametrize("kind", ["combined", "likelihood", "inverse"])
def test_pose_brightness_kinds_match_their_formulas(kind):
    rng = np.random.default_rng(5)
    N = 9
    P = rng.normal(size=(N, 3)) * [2.0, 1.0, 0.1]
    ll = rng.normal(size=N) * 3.0 - 10.0
    M0 = ll.max()
    fit = np.empty(N)
    fs.cloud_distance_brightness(P, ll, M0, fit, fs.POSE_BRIGHTNESS[kind])
    var = P.var(axis=0) + 1e-12
    d2 = (((P - P.mean(axis=0)) ** 2) / var).sum(axis=1)
    want = {"combined": np.exp(ll - M0 - d2 / 2), "likelihood": np.exp(ll - M0),
            "inverse": 1.0 / (1.0 + np.sqrt(-2.0 * (ll - M0) + d2))}[kind]
    assert np.allclose(fit, want, rtol=1e-12)


# --- directional resampling --------------------------------------------------------------------

def _sets(N, M, rng):
    ps = fs.new_particles(N, M, np.zeros(3))
    ps.P[:] = rng.normal(size=(N, 3))
    ps.mu[:] = rng.normal(size=(N, M, 2))
    ps.sig[:] = np.abs(rng.normal(size=(N, M, 3)))
    ps.seen[:] = 1
    ps.nl[:] = M
    ps.src[:] = np.arange(M)
    return ps


@pytest.mark.parametrize("dmap", ["board", "best"])
def test_directional_copies_carry_the_map_the_key_names(dmap):
    """The lower half becomes the board's pose moved by the estimate's change (eq. 10), with the
    board's map or this observation's best particle's; the upper half is drawn from the heavier
    half by the scheme directional_scheme."""
    rng = np.random.default_rng(2)
    N, M = 10, 3
    params = _params("fastslam", association="nearest", resampling="directional",
                     directional_map=dmap, directional_scheme="multinomial",
                     directional_noise_m=0.0, directional_noise_deg=0.0)
    o = fs.options(_course(), params, N, False)
    assert o.dir_scheme == 0 and o.dir_map == fs.DIRECTIONAL_MAPS[dmap]
    ps, out = _sets(N, M, rng), fs.new_particles(N, M, np.zeros(3))
    board, best = _sets(1, M, rng), _sets(1, M, rng)
    W = rng.gamma(1.0, size=N)
    W /= W.sum()
    xbar, xbar_prev = np.array([1.0, 2.0, 0.3]), np.array([0.5, 1.0, 0.1])
    fs.resample_set(ps, out, np.zeros((N, 6)), np.zeros(6), W, W.copy(), 1.0, o, board, best,
                    xbar, xbar_prev, fs.directional_noise(params), np.empty(N, dtype=np.int64),
                    np.zeros(N, dtype=np.int8), _state(1))
    src = board if dmap == "board" else best
    for i in range(N - N // 2, N):
        assert np.allclose(out.P[i], board.P[0] + xbar - xbar_prev, atol=1e-12)
        assert np.array_equal(out.mu[i], src.mu[0]) and np.array_equal(out.sig[i], src.sig[0])
    heavier = np.argsort(-W, kind="stable")[: N - N // 2]
    for i in range(N - N // 2):
        assert any(np.array_equal(out.P[i], ps.P[j]) for j in heavier)


def test_directional_scheme_draws_the_kept_half_by_its_scheme():
    """Multinomial and systematic draws of the kept half differ on the same state, and both keep
    only the heavier half's particles."""
    rng = np.random.default_rng(8)
    N, M = 40, 2
    W = rng.gamma(0.5, size=N)
    W /= W.sum()
    ps = _sets(N, M, rng)
    board = _sets(1, M, rng)
    heavier = set(np.argsort(-W, kind="stable")[: N - N // 2])
    got = {}
    for scheme in (0, 1):
        out = [np.empty_like(a) for a in ps]
        fs.directional_resample(W, *ps, board.P[0], board.mu[0], board.sig[0], board.seen[0],
                                board.nl[0], board.src[0], np.zeros(3),
                                fs.DirectionalNoise(0.0, 0.0), scheme, _state(6), *out)
        rows = [next(j for j in range(N) if np.array_equal(out[0][i], ps.P[j]))
                for i in range(N - N // 2)]
        assert set(rows) <= heavier
        got[scheme] = sorted(rows)
    assert got[0] != got[1]


# --- each choice end to end on a tiny config ---------------------------------------------------

def test_each_reading_runs_end_to_end(tmp_path):
    course = ROOT / "configs/worlds/ifa_course.yaml"
    cfg = tmp_path / "slam.yaml"
    cfg.write_text(f"""seed: 4
trials: 2
scenario: {{name: waypoint_course, world: {course}, steps: 400}}
filters:
  ifa: {{type: fastslam, label: IFA, particles: 15, refine: ifa}}
  fixed: {{type: fastslam, label: fixed unit, particles: 15, refine: ifa, step_unit: fixed,
           step_unit_m: 0.3, step_unit_rad: 0.02}}
  lik: {{type: fastslam, label: likelihood, particles: 15, refine: ifa,
         pose_brightness: likelihood}}
  inv: {{type: fastslam, label: inverse, particles: 15, refine: ifa, pose_brightness: inverse}}
  ba: {{type: fastslam, label: BA fixed, particles: 15, refine: ba, step_unit: fixed}}
  dir: {{type: fastslam, label: directional, particles: 15, resampling: directional,
         resample: always}}
  dir_best: {{type: fastslam, label: best map, particles: 15, resampling: directional,
              resample: always, directional_map: best, directional_scheme: multinomial}}
""")
    import pandas as pd
    run_experiment(load(cfg), tmp_path / "a", workers=1)
    t = pd.read_csv(tmp_path / "a/trials.csv")
    assert len(t) == 14 and np.isfinite(t["rmse"]).all()
    by = t.groupby("label")["rmse"].apply(tuple)
    for label in ("fixed unit", "likelihood", "inverse"):
        assert by[label] != by["IFA"], label
    assert by["best map"] != by["directional"]
    field = ROOT / "configs/worlds/beacon_field.yaml"
    cfg = tmp_path / "srl.yaml"
    cfg.write_text(f"""seed: 4
trials: 2
scenario: {{name: beacon_field, world: {field}, steps: 30, sensor: range_bearing}}
filters:
  srl: {{type: mcl, label: SRL, particles: 200, reset: srl}}
  lv: {{type: mcl, label: LV, particles: 200, reset: srl, srl_rule: lenser_veloso}}
""")
    run_experiment(load(cfg), tmp_path / "b", workers=1)
    t = pd.read_csv(tmp_path / "b/trials.csv")
    assert len(t) == 4 and np.isfinite(t["rmse"]).all()
