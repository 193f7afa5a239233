"""The SLAM kind's measurement models: a SLAM model may bring its own log-likelihood of one
range-bearing observation of one landmark and its own sampler of a step's observations
(pfbench.models.slam SLAM_LIK_SIG, SLAM_SAMPLE_SIG); landmark_world's range and bearing outliers
are the built-in example, which FastSLAM (Gaussian measurement and Jacobians) refuses unless told
to weigh them as Gaussian, and which a particle SLAM filter written as a plug-in here weighs by.
The beacon field's bearing outliers are drawn and weighed the same way."""
import dataclasses
import math

import numpy as np
import pytest
from numba import njit
from scipy import stats
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import Params, validate
from pfbench.errors import UserError
from pfbench.filters import FILTERS
from pfbench.filters.types import FilterType
from pfbench.kernels import SCHEME_SYSTEMATIC, normal, resample, uniform, wrap
from pfbench.kinds import KINDS, check_outputs
from pfbench.models.beacons import SCAN_LIK_SIG, mixture_loglik
from pfbench.models.slam import (SLAM_LIK_SIG, SLAM_SAMPLE_SIG, slam_mixture_loglik,
                                 slam_mixture_theta)
from pfbench.protocols import compatibility, provided
from pfbench.rng import state_from_seed
from pfbench.scenarios import SCENARIOS
from pfbench.scenarios import beacon_field as bf
from pfbench.scenarios import landmark_world as lw
from pfbench.schema import ConfigError

from .conftest import ROOT, one_line_exit_2, tree

WORLD = str(ROOT / "configs" / "worlds" / "afsa_world.yaml")
FIELD = str(ROOT / "configs" / "worlds" / "beacon_field.yaml")


def _params(**over) -> dict:
    p = {k: v.default for k, v in lw.SCHEMA.items()}
    p.update(over)
    return lw.resolve(p, ROOT / "configs")


def _world(**over):
    return lw.build(_params(**over))


def _trial(model, seed):
    return lw.simulate(model, state_from_seed(np.random.SeedSequence(seed)))[0]


def _truth_zs(model, truth):
    """Each observation's measured and true [range, bearing]: (z (n, 2), true (n, 2))."""
    z, true = [], []
    every = int(model.sensor.every)
    for k in range(truth.obs_n.size):
        x, y, th = truth.pose[(k + 1) * every]
        for j in range(truth.obs_n[k]):
            lx, ly = model.landmarks[truth.obs_id[k, j]]
            z.append(truth.obs_z[k, j])
            true.append((math.hypot(lx - x, ly - y), math.atan2(ly - y, lx - x) - th))
    return np.array(z), np.array(true)


# --- without outliers nothing changes ------------------------------------------------------

def test_without_outliers_the_model_is_the_gaussian_sensor_and_its_draws_unchanged():
    plain = _world(steps=60)
    assert plain.loglik is None and plain.sample is None and plain.theta.size == 0
    assert plain.provides() == {"likelihood", "jacobians", "gaussian_measurement"}
    assert _world(steps=60, outlier_likelihood="gaussian").sample is None
    a = _trial(plain, 1)
    # the built-in sampler without outliers draws what sense_landmarks draws, number for number
    own = dataclasses.replace(plain, sample=lw.slam_mixture_sample,
                              theta=slam_mixture_theta(plain.sensor, plain.noise, 0.0, 0.0))
    b = _trial(own, 1)
    for key in ("pose", "ctrl", "obs_n", "obs_id", "obs_z"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key


def test_the_likelihood_without_outliers_is_the_gaussian_sensors_log_density():
    model = _world()
    fn, theta = model.likelihood_function()
    rng = np.random.default_rng(0)
    X, Y, H = rng.uniform(-20, 20, 40), rng.uniform(-20, 20, 40), rng.uniform(-4, 4, 40)
    LX, LY = rng.uniform(-25, 25, 40), rng.uniform(-25, 25, 40)
    out = np.empty(40)
    fn(X, Y, H, LX, LY, 7.5, 3.1, theta, out)
    r = np.hypot(LX - X, LY - Y)
    u = (3.1 - (np.arctan2(LY - Y, LX - X) - H) + math.pi) % (2 * math.pi) - math.pi
    want = (stats.norm.logpdf(7.5, r, model.noise.range)
            + stats.norm.logpdf(u, 0.0, model.noise.bearing))
    np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-9)


# --- the outlier mixture ---------------------------------------------------------------------

@pytest.mark.parametrize("fov", [360.0, 120.0])
def test_the_mixture_loglik_is_the_log_of_the_mixtures_closed_form(fov):
    eps_r, eps_b = 0.2, 0.1
    model = _world(range_outliers=eps_r, bearing_outliers=eps_b, field_of_view_deg=fov,
                   range_noise_m=0.3, bearing_noise_deg=5.0)
    assert model.loglik is not None and model.has_likelihood
    sr, sb = model.noise.range, model.noise.bearing
    rmax, half = model.sensor.max_range, model.sensor.half_fov
    rng = np.random.default_rng(1)
    X, Y, H = rng.uniform(-5, 5, 30), rng.uniform(-5, 5, 30), rng.uniform(-4, 4, 30)
    LX, LY = X + rng.uniform(-8, 8, 30), Y + rng.uniform(-8, 8, 30)
    out = np.empty(30)
    # ranges inside and past [0, rmax]; bearings inside the field of view and (fov 120) past it
    for zr, zb in ((6.0, 0.4), (0.1, -0.9), (rmax + 0.5, 0.2), (3.0, 2.5)):
        slam_mixture_loglik(X, Y, H, LX, LY, zr, zb, model.theta, out)
        r = np.hypot(LX - X, LY - Y)
        u = (zb - (np.arctan2(LY - Y, LX - X) - H) + math.pi) % (2 * math.pi) - math.pi
        rng_part = np.logaddexp(math.log1p(-eps_r) + stats.norm.logpdf(zr, r, sr),
                                math.log(eps_r) + stats.uniform.logpdf(zr, 0.0, rmax))
        brg_part = np.logaddexp(math.log1p(-eps_b) + stats.norm.logpdf(u, 0.0, sb),
                                math.log(eps_b) + stats.uniform.logpdf(zb, -half, 2 * half))
        np.testing.assert_allclose(out, rng_part + brg_part, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("what", ["range", "bearing"])
def test_the_sampler_draws_outliers_at_their_rate_uniform_over_their_support(what):
    """A fixed seed, about 5000 observations: the count of outliers is within the binomial's
    two-sided 99.9% interval (scipy.stats.binomtest p > 1e-3) and they are uniform (KS p > 1e-3).
    The noise is tiny, so that an observation off its true value by more than 1e-4 is an outlier
    (an outlier that close: a chance below 1e-4)."""
    eps = 0.2
    over = {"range_outliers": eps} if what == "range" else {"bearing_outliers": eps}
    model = _world(steps=1000, range_noise_m=1e-7, bearing_noise_deg=1e-6,
                   outlier_likelihood="gaussian", **over)
    assert model.sample is not None and model.loglik is None
    assert model.provides() == {"likelihood", "jacobians", "gaussian_measurement"}
    z, true = _truth_zs(model, _trial(model, 8))
    assert z.shape[0] > 4000
    dr = np.abs(z[:, 0] - true[:, 0])
    db = np.abs((z[:, 1] - true[:, 1] + math.pi) % (2 * math.pi) - math.pi)
    out, other = (dr > 1e-4, db > 1e-4) if what == "range" else (db > 1e-4, dr > 1e-4)
    assert not other.any()
    assert stats.binomtest(int(out.sum()), z.shape[0], eps).pvalue > 1e-3
    col, support = (0, stats.uniform(0.0, model.sensor.max_range)) if what == "range" else \
        (1, stats.uniform(-model.sensor.half_fov, 2 * model.sensor.half_fov))
    assert stats.kstest(z[out, col], support.cdf).pvalue > 1e-3


def test_a_function_of_the_wrong_signature_is_refused_in_one_line():
    @njit(SCAN_LIK_SIG)
    def scan_like(X, Y, H, bc, m, ids, zs, theta, out):
        out[:] = 0.0

    for field, sig in (("loglik", "SLAM_LIK_SIG"), ("sample", "SLAM_SAMPLE_SIG")):
        with pytest.raises(UserError) as err:
            dataclasses.replace(_world(), **{field: scan_like})
        assert "\n" not in str(err.value) and sig in str(err.value)
    # the built-in pair is of the signatures
    assert slam_mixture_loglik.get_compile_result(SLAM_LIK_SIG) is not None
    assert lw.slam_mixture_sample.get_compile_result(SLAM_SAMPLE_SIG) is not None


# --- what FastSLAM needs -----------------------------------------------------------------------

def _config(tmp_path, fname: str, **keys) -> str:
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(f"trials: 2\nscenario:\n  name: landmark_world\n  world: {WORLD}\n  steps: 5\n"
                   + "".join(f"  {k}: {v}\n" for k, v in keys.items())
                   + f"filters:\n  {fname}:\n    particles: 20\n")
    return str(cfg)


def test_fastslam_is_refused_on_outliers_weighed_by_their_mixture_in_one_line(tmp_path):
    assert FILTERS["fastslam"].runs_on("landmark_world", "slam", SCENARIOS["landmark_world"])
    assert compatibility(FILTERS, SCENARIOS)["slam"][2]["landmark_world", "fastslam"] == ()
    runner = CliRunner()
    for keys in ({"range_outliers": 0.2}, {"bearing_outliers": 0.05}):
        cfg = _config(tmp_path, "fastslam", **keys)
        before = tree(tmp_path)
        for cmd in (["validate", cfg],
                    ["run", cfg, "--out", str(tmp_path / "out"), "--no-figures"]):
            line = one_line_exit_2(runner.invoke(app, cmd))
            assert "filter type 'fastslam'" in line and "scenario 'landmark_world'" in line
            assert "['gaussian_measurement']" in line and "['jacobians']" not in line, line
        assert tree(tmp_path) == before
    # outliers weighed as Gaussian: FastSLAM runs (on a sensor it mis-models)
    validate({"trials": 1, "scenario": {"name": "landmark_world", "world": WORLD,
                                        "range_outliers": 0.2, "outlier_likelihood": "gaussian"},
              "filters": {"fastslam": {"particles": 10}}})
    have = provided(lw, _params(range_outliers=0.2), ("gaussian_measurement", "jacobians"))
    assert have == {"jacobians", "likelihood"}


def test_the_keys_refuse_an_outlier_rate_of_one():
    for key in ("range_outliers", "bearing_outliers"):
        with pytest.raises(ConfigError, match=key):
            validate({"trials": 1, "scenario": {"name": "landmark_world", "world": WORLD,
                                                key: 1.0},
                      "filters": {"fastslam": {"particles": 10}}})


# --- a particle SLAM filter of a plug-in, weighing by the model's likelihood ---------------------

@njit(cache=False)
def _pslam_kernel(ctrl, obs_n, obs_id, obs_z, every, start, qxy, qth, N, loglik, theta, s,
                  pose, ess, lm_est, lm_seen):
    """A particle filter whose particles carry a pose and a point estimate of each landmark: a
    landmark's estimate is the inverse measurement of one of its sightings from the particle's
    own pose, kept by reservoir sampling (every sighting equally likely to be the one kept), so
    that the weights, by the model's likelihood of each sighting of a mapped landmark, select
    the particles whose maps come from good sightings. Odometry-form motion (landmark_world's).
    Returns the steps whose log-weights were all -inf."""
    T, M = ctrl.shape[0], lm_est.shape[0]
    X, Y, H = np.full(N, start[0]), np.full(N, start[1]), np.full(N, start[2])
    LX, LY = np.zeros((M, N)), np.zeros((M, N))
    seen = np.zeros(M, dtype=np.int64)
    lw, ll, w = np.zeros(N), np.empty(N), np.empty(N)
    idx = np.empty(N, dtype=np.int64)
    pose[0, 0], pose[0, 1], pose[0, 2] = start[0], start[1], start[2]
    under = 0
    k = 0
    for t in range(T):
        for i in range(N):
            H[i] = H[i] + ctrl[t, 1] + qth * normal(s)
            X[i] += ctrl[t, 0] * math.cos(H[i]) + qxy * normal(s)
            Y[i] += ctrl[t, 0] * math.sin(H[i]) + qxy * normal(s)
            H[i] = wrap(H[i])
        if (t + 1) % every == 0 and k < obs_n.size:
            for j in range(obs_n[k]):
                m = obs_id[k, j]
                zr, zb = obs_z[k, j, 0], obs_z[k, j, 1]
                if seen[m] > 0:
                    loglik(X, Y, H, LX[m], LY[m], zr, zb, theta, ll)
                    lw += ll
                seen[m] += 1
                for i in range(N):
                    if uniform(s) * seen[m] < 1.0:
                        LX[m, i] = X[i] + zr * math.cos(H[i] + zb)
                        LY[m, i] = Y[i] + zr * math.sin(H[i] + zb)
            mx = lw.max()
            if not np.isfinite(mx):
                under += 1
                lw[:] = 0.0
                mx = 0.0
            w[:] = np.exp(lw - mx)
            S = w.sum()
            ess[k] = S * S / (w * w).sum()
            if ess[k] < 0.5 * N:
                resample(SCHEME_SYSTEMATIC, w, S, s, idx)
                X, Y, H = X[idx].copy(), Y[idx].copy(), H[idx].copy()
                LX, LY = np.ascontiguousarray(LX[:, idx]), np.ascontiguousarray(LY[:, idx])
                lw[:] = 0.0
            k += 1
        mx = lw.max()
        w[:] = np.exp(lw - mx)
        w /= w.sum()
        pose[t + 1, 0], pose[t + 1, 1] = (w * X).sum(), (w * Y).sum()
        pose[t + 1, 2] = math.atan2((w * np.sin(H)).sum(), (w * np.cos(H)).sum())
    for m in range(M):
        lm_seen[m] = 1 if seen[m] > 0 else 0
        lm_est[m, 0], lm_est[m, 1] = (w * LX[m]).sum(), (w * LY[m]).sum()
    return under


def _pslam_run(model, data, params, particles, state, diag=True):
    """The plug-in's run: weighs by the model's own likelihood, or the Gaussian sensor's."""
    fn, theta = model.likelihood_function()
    T, K, M = data.ctrl.shape[0], data.obs_n.shape[0], model.landmarks.shape[0]
    out = {"pose": np.empty((T + 1, 3)), "ess": np.zeros(K), "lm_est": np.zeros((M, 2)),
           "lm_seen": np.zeros(M, dtype=np.int64)}
    out["underflow_steps"] = float(_pslam_kernel(
        data.ctrl, data.obs_n, data.obs_id, data.obs_z, int(model.sensor.every), model.start,
        model.noise.drive, model.noise.turn, int(particles), fn, theta, state, out["pose"],
        out["ess"], out["lm_est"], out["lm_seen"]))
    out["lik_evals_per_step"] = float(data.obs_n.mean()) if K else 0.0
    return out


PSLAM = FilterType("pslam", "particle SLAM with point landmarks weighed by the model's "
                   "likelihood (a test plug-in)", {}, _pslam_run, kind="slam",
                   scenarios=("landmark_world",), needs=("likelihood",))


def _score(model, truth, data, out):
    kind = KINDS["slam"]
    return kind.score(model, truth, check_outputs(kind, out, model, truth, data))


@pytest.mark.slow     # a plug-in's kernel compiled outside the cache (7 CPU-s), runs of 300 steps
@pytest.mark.parametrize("over", [{}, {"range_outliers": 0.2, "bearing_outliers": 0.05}])
def test_a_plug_in_particle_slam_filter_runs_through_the_models_likelihood(over, monkeypatch):
    monkeypatch.setitem(FILTERS, "pslam", PSLAM)
    exp = validate({"trials": 1, "scenario": {"name": "landmark_world", "world": WORLD,
                                              "steps": 300, **over},
                    "filters": {"pslam": {"particles": 200}}})
    model = SCENARIOS["landmark_world"].build(dict(exp.scenario_params))
    assert model.has_likelihood == bool(over)
    truth, data = lw.simulate(model, state_from_seed(np.random.SeedSequence(3)))
    out = _pslam_run(model, data, Params({}), 200, state_from_seed(np.random.SeedSequence(4)))
    metrics = _score(model, truth, data, out)
    assert np.isfinite(out["pose"]).all() and out["underflow_steps"] == 0
    # a map: every landmark seen is mapped, and those seen 10 times or more (whose sightings
    # cannot all be outliers) within a metre on the average
    sightings = np.zeros(model.landmarks.shape[0], dtype=np.int64)
    for k in range(data.obs_n.size):
        sightings[data.obs_id[k, :data.obs_n[k]]] += 1
    assert np.array_equal(out["lm_seen"].astype(bool), sightings > 0)
    often = sightings >= 10
    assert often.sum() >= 5
    err = np.hypot(*(out["lm_est"][often] - model.landmarks[often]).T)
    assert err.mean() < 1.0, err
    assert math.isfinite(metrics["rmse"]) and metrics["rmse"] < 1.0, metrics["rmse"]


@pytest.mark.slow     # 20 runs of 300 steps, and the plug-in's kernel above
def test_a_particle_slam_filter_weighing_by_the_mixture_beats_one_weighing_by_the_gaussian():
    """The same plug-in and data, 10 trials of 300 steps, a fifth of the ranges outliers: its
    pose RMSE is smaller when it weighs by the model's mixture than by the Gaussian sensor
    alone (one-sided Wilcoxon signed-rank test at 1%)."""
    mix = _world(steps=300, range_outliers=0.2)
    gauss = _world(steps=300, range_outliers=0.2, outlier_likelihood="gaussian")
    a, b = [], []
    for seed in range(10):
        truth, data = lw.simulate(mix, state_from_seed(np.random.SeedSequence(50 + seed)))
        for model, errs in ((mix, a), (gauss, b)):
            out = _pslam_run(model, data, Params({}), 200,
                             state_from_seed(np.random.SeedSequence(seed)))
            errs.append(_score(model, truth, data, out)["rmse"])
    assert np.mean(a) < np.mean(b)
    assert stats.wilcoxon(a, b, alternative="less").pvalue < 0.01


# --- the beacon field's bearing outliers -----------------------------------------------------

def _field(**over):
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(over)
    return bf.build(bf.resolve(p, ROOT / "configs"))


def test_the_beacon_fields_bearing_outliers_are_drawn_at_their_rate_and_weighed_by_the_mixture():
    eps_b, T = 0.2, 3000
    model = _field(sensor="range_bearing", bearing_outliers=eps_b, bearing_noise_deg=1e-6,
                   range_noise_m=1e-6, steps=T)
    assert model.loglik is not None and model.provides() == {"likelihood"}
    truth, _ = bf.simulate(model, state_from_seed(np.random.SeedSequence(9)))
    db, dr = [], []
    for t in range(T):
        x, y, th = truth.pose[t + 1]
        for j in range(truth.obs_n[t]):
            bx, by = model.beacons[truth.obs_id[t, j]]
            dr.append(abs(truth.obs_z[t, j, 0] - math.hypot(bx - x, by - y)))
            u = truth.obs_z[t, j, 1] - (math.atan2(by - y, bx - x) - th)
            db.append(abs((u + math.pi) % (2 * math.pi) - math.pi))
    db, dr = np.array(db), np.array(dr)
    assert db.size > 4000 and (dr < 1e-4).all()
    assert stats.binomtest(int((db > 1e-4).sum()), db.size, eps_b).pvalue > 1e-3
    # its likelihood: the range Gaussian, the bearing the mixture over the field of view
    m = _field(sensor="range_bearing", bearing_outliers=eps_b)
    X, Y, H = np.array([10.0, 20.0]), np.array([15.0, 5.0]), np.array([0.3, -2.0])
    ids, zs = np.array([1, 4]), np.array([[12.0, 0.7], [8.0, -2.9]])
    out = np.empty(2)
    mixture_loglik(X, Y, H, m.beacons, 2, ids, zs, m.theta, out)
    for i in range(2):
        want = 0.0
        for j, b in enumerate(ids):
            d = m.beacons[b] - (X[i], Y[i])
            want += stats.norm.logpdf(zs[j, 0], math.hypot(*d), m.sense.sr)
            u = (zs[j, 1] - (math.atan2(d[1], d[0]) - H[i]) + math.pi) % (2 * math.pi) - math.pi
            want += np.logaddexp(math.log1p(-eps_b) + stats.norm.logpdf(u, 0.0, m.sense.sb),
                                 math.log(eps_b) - math.log(2 * math.pi))
        assert out[i] == pytest.approx(want, rel=1e-10, abs=1e-10)


def test_the_beacon_fields_bearing_outliers_need_bearings():
    with pytest.raises(ConfigError, match="bearing_outliers"):
        validate({"trials": 1, "scenario": {"name": "beacon_field", "world": FIELD,
                                            "bearing_outliers": 0.1},
                  "filters": {"mcl": {"particles": 10}}})
    plain = _field(sensor="range_bearing")
    assert plain.loglik is None and plain.sample is None
