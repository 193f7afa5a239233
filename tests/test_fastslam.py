"""FastSLAM on the waypoint course: the landmark EKF, exact limits, the course, determinism."""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfbench.angles import wrap
from pfbench.config import Params, load
from pfbench.filters import FILTERS
from pfbench.filters.fastslam import ekf_landmark_update, init_landmark
from pfbench.rng import state_from_seed
from pfbench.runner import run_experiment
from pfbench.store import TIMING_COLUMNS
from pfbench.scenarios import waypoint_course as wc

from .conftest import ROOT


def _model(**over):
    p = {k: v.default for k, v in wc.SCHEMA.items()}
    p.update(over)
    return wc.build(wc.resolve(p, ROOT / "configs"))


def _run(model, data, N, seed=0, **over):
    ft = FILTERS["fastslam"]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    return ft.run(model, data, Params(p), N, state_from_seed(np.random.SeedSequence(seed)))


def test_wrap_at_plus_minus_pi():
    assert wrap(math.pi) == -math.pi
    assert wrap(-math.pi) == -math.pi
    assert wrap(3 * math.pi) == pytest.approx(-math.pi)
    assert wrap(math.pi - 1e-9) == pytest.approx(math.pi - 1e-9)
    assert wrap(-7.0) == pytest.approx(-7.0 + 2 * math.pi)


@pytest.mark.parametrize("pose,lm,z", [((1.0, 2.0, 0.3), (7.0, 5.0), (6.9, 0.15)),
                                       ((0.0, 0.0, 3.1), (-5.0, 0.1), (5.05, -3.1)),
                                       ((3.0, -1.0, -2.0), (2.0, -9.0), (8.2, -0.5))])
def test_landmark_ekf_update_matches_numpy(pose, lm, z):
    px, py, pth = pose
    Rr, Rb = 0.09, (math.pi / 180) ** 2
    mu = np.array(lm, dtype=float)
    P = np.array([[0.5, 0.1], [0.1, 0.3]])
    sig = np.array([P[0, 0], P[0, 1], P[1, 1]])
    # reference: plain matrix algebra
    dx, dy = mu - [px, py]
    q = dx * dx + dy * dy
    zhat = np.array([math.sqrt(q), math.atan2(dy, dx) - pth])
    H = np.array([[dx / math.sqrt(q), dy / math.sqrt(q)], [-dy / q, dx / q]])
    R = np.diag([Rr, Rb])
    S = H @ P @ H.T + R
    v = np.array(z) - zhat
    v[1] = (v[1] + math.pi) % (2 * math.pi) - math.pi
    K = P @ H.T @ np.linalg.inv(S)
    mu_ref = mu + K @ v
    A = np.eye(2) - K @ H
    P_ref = A @ P @ A.T + K @ R @ K.T
    ll_ref = -0.5 * v @ np.linalg.solve(S, v) - 0.5 * math.log(np.linalg.det(2 * math.pi * S))
    ll = ekf_landmark_update(px, py, pth, mu, sig, z[0], z[1], Rr, Rb, 1)
    assert np.allclose(mu, mu_ref, atol=1e-12)
    assert np.allclose(sig, [P_ref[0, 0], P_ref[0, 1], P_ref[1, 1]], atol=1e-12)
    assert ll == pytest.approx(ll_ref, abs=1e-10)
    # the simple form gives the same update up to round-off when the gain is optimal
    mu2 = np.array(lm, dtype=float)
    sig2 = np.array([P[0, 0], P[0, 1], P[1, 1]])
    ekf_landmark_update(px, py, pth, mu2, sig2, z[0], z[1], Rr, Rb, 0)
    assert np.allclose(sig2, sig, atol=1e-12)


def test_new_landmark_sits_where_it_was_seen():
    mu, sig = np.empty(2), np.empty(3)
    init_landmark(1.0, 2.0, 0.5, 10.0, -0.2, 0.09, 1e-4, mu, sig)
    assert mu == pytest.approx([1 + 10 * math.cos(0.3), 2 + 10 * math.sin(0.3)])
    assert sig[0] > 0 and sig[2] > 0 and sig[0] * sig[2] > sig[1] ** 2


def test_course_lap_takes_its_length_over_the_speed():
    model = _model(laps=1, steps=20000, speed_noise_mps=0.0, steer_noise_deg=0.0)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(0)))
    wp = model.waypoints
    lap = np.sum(np.hypot(*np.diff(np.r_[wp, wp[:1]], axis=0).T)) + np.hypot(*wp[0])
    expected = lap / (model.vehicle[0] * model.vehicle[1])
    assert data.steps < 20000                       # the lap ended the run
    assert abs(data.steps / expected - 1) < 0.1     # corners cut within the 1 m radius
    assert set(np.unique(data.waypoint)) == set(range(len(wp)))


def test_without_noise_fastslam_follows_the_truth():
    model = _model(steps=2000, speed_noise_mps=0.0, steer_noise_deg=0.0, range_noise_m=1e-9,
                   bearing_noise_deg=1e-9)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(1)))
    out = _run(model, data, 5, predict_noise=False)
    assert np.max(np.abs(out["pose"] - truth.pose)) < 1e-9
    seen = out["lm_seen"].astype(bool)
    assert seen.sum() >= 5
    assert np.max(np.abs(out["lm_est"][seen] - model.landmarks[seen])) < 1e-6


def test_one_particle_without_prediction_noise_is_dead_reckoning():
    model = _model(steps=1500)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(2)))
    out = _run(model, data, 1, predict_noise=False)
    dt, L = model.vehicle[1], model.vehicle[2]
    x, y, th = model.start
    ref = [(x, y, th)]
    for V, G in data.ctrl:
        x += V * dt * math.cos(th + G)
        y += V * dt * math.sin(th + G)
        th = wrap(th + V * dt * math.sin(G) / L)
        ref.append((x, y, th))
    assert np.allclose(out["pose"], np.array(ref), atol=1e-9)
    # sanity bound: dead reckoning with 0.5 m/s and 5 deg control noise drifts, but not wildly
    err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
    assert 0.0 < err[-1] < 50.0


def test_a_particle_with_no_landmark_in_range_keeps_its_weight():
    model = _model(steps=800)
    model = replace(model, sensor=np.array([1e-3, math.pi, 8.0]))   # a sensor that sees nothing
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(3)))
    assert data.obs_n.sum() == 0
    out = _run(model, data, 50)
    assert np.allclose(out["ess"], 50.0)
    assert out["resampled"].sum() == 0


def test_slam_trials_are_bit_identical_across_workers(tmp_path):
    cfg = tmp_path / "fs.yaml"
    cfg.write_text(f"""seed: 4
trials: 4
scenario: {{name: waypoint_course, world: {ROOT / 'configs/worlds/ifa_course.yaml'}, steps: 400}}
filters:
  fastslam: {{label: FastSLAM, particles: 20}}
  ifa: {{type: fastslam, label: IFA-FastSLAM, particles: 20, refine: ifa}}
""")
    exp = load(cfg)
    run_experiment(exp, tmp_path / "a", workers=1)
    run_experiment(exp, tmp_path / "b", workers=2)
    # a trials file holds only what the seed determines: the same bytes for any workers
    assert (tmp_path / "a/trials.csv").read_bytes() == (tmp_path / "b/trials.csv").read_bytes()
    a = pd.read_csv(tmp_path / "a/trials.csv")
    assert not set(TIMING_COLUMNS) & set(a.columns)
    assert np.isfinite(a["rmse"]).all() and np.isfinite(a["landmark_error"]).all()


def test_world_file_errors_name_the_problem(tmp_path, write_config):
    bad = tmp_path / "w.yaml"
    bad.write_text("area: [10, 10]\nstart: [0, 0, 0]\nwaypoints: [[0, 1], [20, 1]]\n"
                   "landmarks: [[1, 1]]\n")
    cfg = write_config(f"scenario: {{name: waypoint_course, world: {bad}}}\n"
                       "filters: {fastslam: {particles: 10}}\n")
    from pfbench.schema import ConfigError
    with pytest.raises(ConfigError, match=r"waypoints\[1\].*outside"):
        load(cfg)
    world = ROOT / "configs/worlds/ifa_course.yaml"
    cfg = write_config(f"scenario: {{name: waypoint_course, world: {world}}}\n"
                       "filters: {pf: {particles: 10}}\n")
    with pytest.raises(ConfigError, match="slam scenario"):
        load(Path(cfg))
    cfg = write_config("scenario: {name: waypoint_course}\nfilters: {fastslam: {particles: 10}}\n")
    with pytest.raises(ConfigError, match="world file .*no such file"):
        load(Path(cfg))


def test_nearest_neighbour_matches_known_association_on_well_separated_landmarks():
    # Poses known exactly (no control noise), small sensor noise and gates that separate a
    # correct match (squared distance ~ 2) from any other landmark (~ 1e4): every observation
    # joins its true landmark and new landmarks start exactly when known association starts
    # them, so the estimates are identical.
    model = _model(steps=1200, speed_noise_mps=0.0, steer_noise_deg=0.0, range_noise_m=0.05,
                   bearing_noise_deg=0.2)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(5)))
    known = _run(model, data, 5, seed=1, predict_noise=False)
    near = _run(model, data, 5, seed=1, predict_noise=False, association="nearest",
                gate_reject=50.0, gate_augment=100.0)
    assert near["association_errors"] == 0.0
    assert np.array_equal(near["pose"], known["pose"])
    assert np.array_equal(near["lm_seen"], known["lm_seen"])
    seen = near["lm_seen"].astype(bool)
    assert np.max(np.abs(near["lm_est"][seen] - model.landmarks[seen])) < 0.5


def test_landmarks_closer_than_the_noise_get_confused(tmp_path):
    world = tmp_path / "twins.yaml"
    lm = [[10.0, 5.0], [10.0, 5.3], [-10.0, -5.0], [-10.0, -5.3], [0.0, 12.0]]
    world.write_text("area: [60, 40]\nstart: [0, 0, 0]\nwaypoints: [[15, 0], [0, 10], [-15, 0], "
                     f"[0, -10]]\nlandmarks: {lm}\n")
    p = {k: v.default for k, v in wc.SCHEMA.items()}
    p.update(world=str(world), steps=3000, speed_mps=2.0, range_noise_m=0.5, bearing_noise_deg=3.0)
    model = wc.build(wc.resolve(p, tmp_path))
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(6)))
    near = _run(model, data, 20, association="nearest")
    assert near["association_errors"] > 0.0


def test_a_full_map_drops_new_landmarks_instead_of_overflowing():
    model = _model(steps=1200)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(7)))
    out = _run(model, data, 10, association="nearest", max_landmarks=2)
    assert out["lm_seen"].sum() <= 2
    assert np.isfinite(out["pose"]).all()


def test_directional_resampling_copies_the_board_into_the_lower_half():
    from pfbench.filters.fastslam import DirectionalNoise, directional_resample
    rng = np.random.default_rng(0)
    N, M = 10, 4
    W = rng.gamma(1.0, size=N)
    W /= W.sum()
    P = rng.normal(size=(N, 3))
    mu = rng.normal(size=(N, M, 2))
    sig = np.abs(rng.normal(size=(N, M, 3)))
    seen = np.ones((N, M), dtype=np.int8)
    nl = np.full(N, M, dtype=np.int64)
    src = np.tile(np.arange(M), (N, 1))
    bP = np.array([5.0, -3.0, 0.2])
    bmu = np.full((M, 2), 7.0)
    bsig = np.full((M, 3), 0.5)
    bseen = np.ones(M, dtype=np.int8)
    bsrc = np.arange(M)
    shift = np.array([1.0, 2.0, 0.1])
    noise = DirectionalNoise(0.01, 0.001)
    out = [np.empty_like(a) for a in (P, mu, sig, seen, nl, src)]
    directional_resample(W, P, mu, sig, seen, nl, src, bP, bmu, bsig, bseen, M, bsrc, shift, noise,
                         1, state_from_seed(np.random.SeedSequence(1)), *out)
    P2, mu2, sig2, seen2, nl2, src2 = out
    assert P2.shape == (N, 3)
    upper = set(np.argsort(-W, kind="stable")[: N - N // 2])
    lower_rows = range(N - N // 2, N)
    # the lower half: the board's pose moved by the shift (within the noise), with its map
    for i in lower_rows:
        assert np.all(np.abs(P2[i] - (bP + shift)) <= 5 * np.array([noise.m, noise.m, noise.rad]))   # 5 standard deviations
        assert np.array_equal(mu2[i], bmu) and np.array_equal(sig2[i], bsig)
    # the upper half: particles of the heavier half, maps and all
    for i in range(N - N // 2):
        j = next(j for j in upper if np.array_equal(P2[i], P[j]))
        assert np.array_equal(mu2[i], mu[j])
    # deep copies: changing one particle's map changes no other
    mu2[N - 1, 0, 0] = -99.0
    assert mu2[N - 2, 0, 0] == 7.0 and bmu[0, 0] == 7.0


def test_directional_resampling_in_a_trial_leaves_uniform_weights():
    model = _model(steps=1600)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(8)))
    out = _run(model, data, 30, resampling="directional", resample="always")
    assert out["resampled"].all()
    assert np.isfinite(out["pose"]).all()
    err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
    assert err.max() < 5.0       # it tracks the course


def test_afsa_refinement_tracks_the_course_and_counts_its_evaluations():
    model = _model(steps=1600)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(9)))
    plain = _run(model, data, 30)
    afsa = _run(model, data, 30, refine="afsa", resampling="directional")
    # per observation: N to find the fitness, 4 N for the centres and the three behaviours, N to
    # weigh the particles
    assert afsa["lik_evals_per_step"] == 6 * 30 and plain["lik_evals_per_step"] == 30
    assert not np.array_equal(afsa["pose"], plain["pose"])
    err = np.hypot(*(afsa["pose"][:, :2] - truth.pose[:, :2]).T)
    assert err.max() < 5.0


def test_pose_covariance_step_matches_the_jacobian_product():
    from pfbench.filters.fastslam import propagate_pose_cov
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    C = A @ A.T
    c = C[np.triu_indices(3)].copy()          # [xx, xy, xt, yy, yt, tt]
    fx, fy, q1, q2, qxy = 0.3, -0.2, 0.04, 0.09, 0.01
    g1, g2 = rng.normal(size=3), rng.normal(size=3)
    propagate_pose_cov(c, fx, fy, *g1, q1, *g2, q2, qxy)
    F = np.array([[1.0, 0.0, fx], [0.0, 1.0, fy], [0.0, 0.0, 1.0]])
    want = (F @ C @ F.T + q1 * np.outer(g1, g1) + q2 * np.outer(g2, g2)
            + np.diag([qxy, qxy, 0.0]))
    assert c == pytest.approx(want[np.triu_indices(3)], rel=1e-12, abs=1e-12)


def test_gate_distance_adds_the_pose_uncertainty_through_the_pose_jacobian():
    from pfbench.filters.fastslam import mahalanobis2
    pose = np.array([1.0, -2.0, 0.4])
    mu, sig = np.array([6.0, 3.0]), np.array([0.04, 0.01, 0.09])
    z = np.array([7.3, 0.42])
    Rr, Rb = 0.01, 0.0004
    C = np.array([[0.02, 0.005, 0.001], [0.005, 0.03, -0.002], [0.001, -0.002, 0.004]])

    def h(p, lm):
        d = lm - p[:2]
        return np.array([np.hypot(*d), wrap(math.atan2(d[1], d[0]) - p[2])])

    eps = 1e-6
    Hx = np.column_stack([(h(pose + eps * e, mu) - h(pose - eps * e, mu)) / (2 * eps)
                          for e in np.eye(3)])
    Hl = np.column_stack([(h(pose, mu + eps * e) - h(pose, mu - eps * e)) / (2 * eps)
                          for e in np.eye(2)])
    P = np.array([[sig[0], sig[1]], [sig[1], sig[2]]])
    v = z - h(pose, mu)
    v[1] = wrap(v[1])
    for cov in (np.zeros((3, 3)), C):
        S = Hl @ P @ Hl.T + Hx @ cov @ Hx.T + np.diag([Rr, Rb])
        got = mahalanobis2(*pose, mu, sig, *z, Rr, Rb, cov[np.triu_indices(3)].copy())
        assert got == pytest.approx(v @ np.linalg.solve(S, v), rel=1e-6)


def test_the_pose_aware_gate_keeps_true_matches_the_plain_gate_rejects():
    # afsa2014's world: the motion noise per step (1 cm, 0.2 deg) exceeds the sensor's (1 cm,
    # 0.1 deg). The plain FastSLAM 1.0 distance then puts most true matches beyond the gates
    # (dropped, or started again as duplicate landmarks); with each particle's pose uncertainty
    # in the distance and the config's gates every observation joins a landmark and each seen
    # landmark is started once per particle, as with known association.
    from pfbench.scenarios import landmark_world as lw
    p = {k: v.default for k, v in lw.SCHEMA.items()}
    p.update(steps=600)
    model = lw.build(lw.resolve(p, ROOT / "configs"))
    truth, data = lw.simulate(model, state_from_seed(np.random.SeedSequence(11)))
    seen = len({int(i) for k in range(data.obs_n.size) for i in data.obs_id[k, :data.obs_n[k]]})
    gates = dict(association="nearest", gate_reject=50.0, gate_augment=2500.0)
    pose = _run(model, data, 10, seed=2, **gates)
    plain = _run(model, data, 10, seed=2, gate_pose=False, **gates)
    assert pose["association_errors"] == 0.0
    assert pose["dropped_frac"] < 0.001
    assert pose["started_per_particle"] == pytest.approx(seen, abs=0.5)
    assert plain["dropped_frac"] > 0.05 or plain["started_per_particle"] > seen + 5


def test_pose_diversity_is_the_mean_pairwise_l1_distance_and_the_distinct_fraction():
    from pfbench.filters.fastslam import pose_diversity
    rng = np.random.default_rng(4)
    P = rng.normal(size=(7, 3))
    P[:, 2] = (rng.normal(0.0, 0.5, 7) + 2 * math.pi) % (2 * math.pi) - math.pi   # across +-pi
    P[5] = P[1]
    P[6] = P[1]                                  # three copies of one particle
    d = [abs(P[i, 0] - P[j, 0]) + abs(P[i, 1] - P[j, 1]) + abs(wrap(P[i, 2] - P[j, 2]))
         for i in range(7) for j in range(i + 1, 7)]
    l1, distinct = pose_diversity(P)
    assert l1 == pytest.approx(np.mean(d), rel=1e-12)
    assert distinct == pytest.approx(5 / 7)
    assert pose_diversity(np.repeat(P[:1], 4, axis=0)) == (0.0, 0.25)
    big = rng.normal(size=(300, 3))
    big[:, 2] *= 0.4                             # a cloud spanning less than pi
    big[::3] = big[1::3]                         # many copies, several sharing x with others
    ref = np.mean([abs(big[i, 0] - big[j, 0]) + abs(big[i, 1] - big[j, 1])
                   + abs(wrap(big[i, 2] - big[j, 2])) for i in range(300) for j in range(i)])
    l1, distinct = pose_diversity(big)
    assert l1 == pytest.approx(ref, rel=1e-9)
    assert distinct == pytest.approx(len({tuple(r) for r in big}) / 300)


def test_slam_diversity_is_measured_after_resampling_only():
    model = _model(steps=800)
    truth, data = wc.simulate(model, state_from_seed(np.random.SeedSequence(12)))
    out = _run(model, data, 20, resample="neff", neff_ratio=0.5)
    r = out["resampled"].astype(bool)
    assert 0 < r.sum() < r.size
    assert np.isnan(out["div_l1"][~r]).all() and np.isfinite(out["div_l1"][r]).all()
    assert ((out["distinct"][r] > 0) & (out["distinct"][r] <= 1)).all()
    # the landmark error trace of the best particle ends near the final map's error
    assert np.isfinite(out["lm_trace"][-1]) and out["lm_trace"][-1] < 2.0


def test_nearest_fitness_never_rewards_pushing_an_observation_out_of_the_gates():
    from pfbench.filters.fastslam import pose_loglik
    mu = np.array([[[5.0, 0.0], [0.0, 5.0]]])
    sig = np.full((1, 2, 3), 0.0)
    sig[0, :, 0] = sig[0, :, 2] = 0.01
    zs = np.array([[5.0, 0.0], [5.0, math.pi / 2]])      # both seen from the origin
    args = (0, mu, sig, np.ones((1, 2), dtype=np.int8), np.arange(2), zs, 2, 0.01, 1e-4, 1, 2,
            100.0, np.zeros((1, 6)))
    at_truth = pose_loglik(0.0, 0.0, 0.0, *args)
    slightly_off = pose_loglik(0.05, 0.0, 0.01, *args)
    far = pose_loglik(3.0, -2.0, 1.0, *args)
    assert at_truth == pytest.approx(0.0, abs=1e-9)
    assert far == pytest.approx(-0.5 * 100.0 * 2)            # both capped at the gate
    assert at_truth > slightly_off > far


def test_nearest_landmark_is_the_exhaustive_search_within_its_bound():
    """The bounded search (lower bounds of the distance skip far landmarks) finds what the plain
    search over ``mahalanobis2`` finds, to the bit, wherever the nearest is within the bound, and
    says 'beyond' (a distance over the bound) where it is not: over random maps, poses, pose
    uncertainties, observations and bounds, near landmarks and far ones, tiny and large gates."""
    from pfbench.filters.fastslam import mahalanobis2, nearest_landmark
    rng = np.random.default_rng(19)
    checked_within = checked_beyond = 0
    for case in range(1500):
        M = int(rng.integers(1, 12))
        mu = rng.uniform(-20, 20, (1, M, 2))
        a = rng.uniform(1e-6, 1.0, M) ** 2
        d = rng.uniform(1e-6, 1.0, M) ** 2
        c = rng.uniform(-0.9, 0.9, M) * np.sqrt(a * d)
        sig = np.stack([a, c, d], axis=1)[None].copy()
        px, py, pth = rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-np.pi, np.pi)
        G = rng.normal(size=(3, 3)) * rng.choice([0.0, 1e-3, 0.1])
        C = G @ G.T
        pc = np.array([C[0, 0], C[0, 1], C[0, 2], C[1, 1], C[1, 2], C[2, 2]])
        Rr, Rb = rng.uniform(1e-4, 0.5) ** 2, np.radians(rng.uniform(0.05, 5.0)) ** 2
        m0 = int(rng.integers(M))
        dx, dy = mu[0, m0] - (px, py)
        zr = np.hypot(dx, dy) + rng.normal() * rng.choice([0.01, 0.5, 3.0])
        zb = np.arctan2(dy, dx) - pth + rng.normal() * rng.choice([0.001, 0.1, 1.0])
        zb = (zb + np.pi) % (2 * np.pi) - np.pi
        bound = float(rng.choice([1e-3, 1.0, 9.0, 200.0, 1e4, np.inf]))
        d2s = [mahalanobis2(px, py, pth, mu[0, m], sig[0, m], zr, zb, Rr, Rb, pc)
               for m in range(M)]
        best = int(np.argmin(d2s)) if np.isfinite(min(d2s)) else -1
        got = nearest_landmark(px, py, pth, 0, mu, sig, M, zr, zb, Rr, Rb, pc, bound)
        if best >= 0 and d2s[best] <= bound:
            assert got == (best, d2s[best]), case
            checked_within += 1
        else:
            assert got[1] > bound, case
            checked_beyond += 1
    assert checked_within > 300 and checked_beyond > 300


def test_the_searchs_innovation_updates_as_ekf_landmark_update_does():
    """update_maps updates the nearest landmark from the innovation the search computed
    (ekf_apply): the same mean, covariance and log-likelihood, bit for bit, as
    ekf_landmark_update computing it again."""
    from pfbench.filters.fastslam import ekf_apply, ekf_landmark_update, nearest_innovation
    rng = np.random.default_rng(23)
    for case in range(300):
        M = int(rng.integers(1, 8))
        mu = rng.uniform(-10, 10, (1, M, 2))
        a, d = rng.uniform(1e-4, 0.5, M) ** 2, rng.uniform(1e-4, 0.5, M) ** 2
        sig = np.stack([a, 0.3 * np.sqrt(a * d), d], axis=1)[None].copy()
        px, py, pth = rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-np.pi, np.pi)
        pc = np.array([1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-5]) * rng.choice([0.0, 1.0])
        m0 = int(rng.integers(M))
        dx, dy = mu[0, m0] - (px, py)
        zr = np.hypot(dx, dy) + 0.05 * rng.normal()
        zb = (np.arctan2(dy, dx) - pth + 0.02 * rng.normal() + np.pi) % (2 * np.pi) - np.pi
        Rr, Rb, joseph = 0.01, 1e-4, int(rng.integers(2))
        fm, d2, v1, v2, S11, S12, S22, h11, h12, h21, h22 = nearest_innovation(
            px, py, pth, 0, mu, sig, M, zr, zb, Rr, Rb, pc, 1e4)
        if not np.isfinite(d2):
            continue
        m = int(fm)
        mu_a, sig_a = mu[0, m].copy(), sig[0, m].copy()
        mu_b, sig_b = mu[0, m].copy(), sig[0, m].copy()
        la = ekf_apply(mu_a, sig_a, v1, v2, S11, S12, S22, S11 * S22 - S12 * S12, h11, h12,
                       h21, h22, Rr, Rb, joseph)
        lb = ekf_landmark_update(px, py, pth, mu_b, sig_b, zr, zb, Rr, Rb, joseph)
        assert la == lb and np.array_equal(mu_a, mu_b) and np.array_equal(sig_a, sig_b), case
