"""Localization on the beacon field: the scenario, MCL and its resetting variants, the SSPF."""
import math
from statistics import NormalDist

import numpy as np
import pytest

from pfbench.metrics import localization_metrics


from pfbench.config import Params  # noqa: E402
from pfbench.filters import FILTERS  # noqa: E402
from pfbench.models.beacons import sensor_pose  # noqa: E402
from pfbench.rng import state_from_seed  # noqa: E402
from pfbench.scenarios import beacon_field as bf  # noqa: E402

from .conftest import ROOT  # noqa: E402


def _field(**over):
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(over)
    return bf.build(bf.resolve(p, ROOT / "configs"))


def _mcl(model, data, N, seed=0, **over):
    ft = FILTERS["mcl"]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    return ft.run(model, data, Params(p), N, state_from_seed(np.random.SeedSequence(seed)))


@pytest.mark.parametrize("sensor", [0, 1])
def test_sensor_model_draws_reproduce_the_observation(sensor):
    area = np.array([40.0, 40.0])
    bc = np.array([[10.0, 12.0], [30.0, 25.0]])
    ids = np.array([1, 0])
    zs = np.array([[7.5, 0.4], [12.0, -1.1]])
    s = state_from_seed(np.random.SeedSequence(3))
    out = np.empty(3)
    for _ in range(200):
        sensor_pose(area, sensor, bc, 2, ids, zs, 1e-9, 1e-9, out, s)
        # the pose sees one of the two observed beacons as observed
        hits = []
        for b, (r, brg) in zip(ids, zs):
            d = bc[b] - out[:2]
            ok = abs(np.hypot(*d) - r) < 1e-6
            if sensor == 1:
                ok &= abs((math.atan2(d[1], d[0]) - out[2] - brg + math.pi) % (2 * math.pi)
                          - math.pi) < 1e-6
            hits.append(ok)
        assert any(hits)


def test_kidnapping_is_invisible_in_the_odometry():
    plain = _field(steps=60)
    kid = _field(steps=60, kidnap_steps=[30], kidnap_poses=[35.0, 35.0, 90.0])
    a, _ = bf.simulate(plain, state_from_seed(np.random.SeedSequence(4)))
    b, _ = bf.simulate(kid, state_from_seed(np.random.SeedSequence(4)))
    assert np.array_equal(a.pose[:30], b.pose[:30]) and np.array_equal(a.ctrl[:30], b.ctrl[:30])
    assert np.array_equal(a.obs_z[:29], b.obs_z[:29])
    assert b.pose[30] == pytest.approx([35.0, 35.0, math.pi / 2])
    # the odometry of the kidnapping step is the commanded move, as if nothing happened
    assert np.array_equal(a.ctrl[29], b.ctrl[29])


def test_mcl_with_precise_sensors_converges_to_the_true_pose():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=60)
    for seed in range(3):
        truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(10 + seed)))
        out = _mcl(model, data, 2000, seed=seed)
        err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
        assert err[-5:].max() < 0.5, seed      # within 0.5 m by the last steps of 60


def test_augmented_mcl_injects_nothing_while_the_likelihood_is_steady_and_after_a_kidnap_does():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=80,
                   kidnap_steps=[50], kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(20)))
    blind = bf.FieldData(data.pose, data.ctrl, np.zeros_like(data.obs_n), data.obs_id, data.obs_z)
    out = _mcl(model, blind, 500, reset="augmented")
    assert out["injected"].sum() == 0                  # no observations: p_mean stays 1
    out = _mcl(model, data, 2000, seed=1, reset="augmented", inject="sensor")
    assert out["injected"][49:60].sum() > 0
    err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
    assert err[-5:].max() < 0.5                        # and it recovers


def test_asrl_replaces_more_particles_the_lower_the_likelihood():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=80,
                   kidnap_steps=[50], kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(21)))
    out = _mcl(model, data, 1000, reset="asrl", asrl_pt=0.5, asrl_mu=1.0)
    n = data.obs_n * 2
    want = np.round(1000 * np.maximum(0.0, 1.0 - out["pmean"] / (1.0 * 0.5 ** n)))
    assert np.array_equal(out["injected"], want.astype(np.int64))
    # the kidnapping (step 50, index 49) leaves no particle near the robot: all are replaced,
    # by poses consistent with that step's observations, and the filter is back at once
    assert out["injected"][49] == 1000 and out["injected"][44] == 0
    err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
    assert err[49] > 5.0 and err[51:].max() < 0.5


def test_beacon_world_errors_name_the_problem(tmp_path):
    from pfbench.schema import ConfigError
    world = tmp_path / "w.yaml"
    world.write_text("area: [40, 40]\nstart: [5, 5, 0]\nwaypoints: [[10, 10], [20, 20]]\n"
                     "beacons: [[5, 20], [45, 10]]\n")
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p["world"] = str(world)
    with pytest.raises(ConfigError, match=r"beacons\[1\] = \[45.0, 10.0\] lies outside"):
        bf.resolve(p, tmp_path)
    p.update(world=str(ROOT / "configs/worlds/beacon_field.yaml"), kidnap_steps=(10,),
             kidnap_poses=(1.0, 2.0))
    with pytest.raises(ConfigError, match="kidnap_poses"):
        bf.resolve(p, tmp_path)


from pfbench.filters.mcl import KldParams, kld_bin, kld_bins, kld_count, kld_sample  # noqa: E402
from pfbench.models.odometry import MotionNoise  # noqa: E402


def _kld_draw(P, kp, seed=0, nmax=100000, noise=0.0):
    area = np.array([40.0, 40.0])
    n = P.shape[0]
    cum = np.cumsum(np.full(n, 1.0 / n))        # the running sums of equal weights
    occ = np.zeros(kld_bins(area, kp), dtype=np.uint8)
    out = np.empty((3, nmax))                  # the kernel keeps particles as rows
    m, inj = kld_sample(np.ascontiguousarray(P.T), cum, n, np.zeros(3), 0,
                        MotionNoise.additive(noise, 0.0), area, kp, nmax,
                        occ, np.empty(nmax, dtype=np.int64), 0.0, 0, 0, np.zeros((1, 2)), 0,
                        np.zeros(1, dtype=np.int64), np.zeros((1, 2)), 0.1, 0.1,
                        state_from_seed(np.random.SeedSequence(seed)), out)
    assert inj == 0 and not occ.any()           # the histogram is left empty for the next step
    return m, out[:, :m].T, area


@pytest.fixture(scope="module")
def kld_one_at_a_time():
    """KLD-sampling as Fox writes it, one particle at a time (draw, move, bin, count; the move
    with vecmath's sine, cosine and wrap, as the kernel's): the reference the kernel's passes
    must reproduce bit for bit."""
    from numba import njit

    from pfbench import vecmath as vm
    from pfbench.models.odometry import noisy_odometry
    from pfbench.rng import uniform

    @njit(cache=False)
    def ref(P, cum, n, u, motion, mnoise, area, kp, nmax, occ, touched, prob, inject_sensor,
            sensor, bc, nobs, ids, zs, sr, sb, s, out):
        acc = cum[n - 1]
        nmin = int(kp[4])
        target = nmin
        k = m = injected = 0
        pose = np.empty(3)
        while m < nmax:
            if prob > 0.0 and uniform(s) < prob:
                sensor_pose(area, sensor, bc, nobs if inject_sensor else 0, ids, zs, sr, sb,
                            pose, s)
                injected += 1
            else:
                j = min(np.searchsorted(cum[:n], uniform(s) * acc, side="right"), n - 1)
                pose[0], pose[1], pose[2] = P[0, j], P[1, j], P[2, j]
            a1, a2, a3 = noisy_odometry(u[0], u[1], u[2], motion, mnoise, s)
            th = pose[2] + a1
            st, ct = vm.sincos(th)
            out[0, m] = pose[0] + a2 * ct
            out[1, m] = pose[1] + a2 * st
            out[2, m] = vm.wrap(th + a3)
            b = kld_bin(out[0, m], out[1, m], out[2, m], area, kp)
            if occ[b] == 0:
                occ[b] = 1
                touched[k] = b
                k += 1
                target = max(nmin, kld_count(k, kp[0], kp[1]))
            m += 1
            if m >= target:
                break
        for r in range(k):
            occ[touched[r]] = 0
        return m, injected

    return ref


def test_kld_sampling_in_passes_is_the_one_at_a_time_loop_bit_for_bit(kld_one_at_a_time):
    # the kernel draws in rounds of passes and takes back the draws past its stopping particle:
    # its particles, count, injections and generator state must be the loop's, over weights
    # spread, peaked or with zeros, spread or clustered sets (few or many bins, stops inside a
    # round or at nmax), both motion models, and injection from the field or the sensor model
    rng = np.random.default_rng(2024)
    area = np.array([40.0, 40.0])
    bc = np.array([[5.0, 5.0], [35.0, 8.0], [20.0, 30.0]])
    ids = np.array([0, 2], dtype=np.int64)
    zs = np.array([[7.0, 0.4], [12.0, -1.1]])
    for case in range(80):
        n = int(rng.choice([1, 2, 7, 100, 3000]))
        spread = float(rng.choice([0.2, 3.0, 40.0]))
        P = np.ascontiguousarray(np.column_stack([
            rng.uniform(0, spread, n), rng.uniform(0, spread, n),
            rng.uniform(-math.pi, math.pi, n)]).T)
        W = rng.random(n) ** float(rng.choice([1.0, 8.0, 40.0]))
        W[rng.random(n) < 0.3] = 0.0
        if not W.any():
            W[-1] = 1.0
        W /= W.sum()
        cum = np.cumsum(W)                      # the running sums, in order (weighted_sums's)
        kp = KldParams(float(rng.choice([0.02, 0.05, 0.3])), NormalDist().inv_cdf(0.99), 0.5,
                       math.radians(10.0), float(rng.choice([1, 20, 300])))
        nmax = int(rng.choice([5, 50, 700, 6000]))
        motion = int(rng.integers(0, 2))
        mnoise = (MotionNoise.rot_trans_rot(0.05, 0.02, 0.1, 0.05) if motion
                  else MotionNoise.additive(0.3, 0.05))
        u = np.array([0.0 if motion == 0 else 0.2, 0.5, -0.1])
        prob = float(rng.choice([0.0, 0.0, 0.05, 0.6]))
        inj_sensor, sensor = int(rng.integers(0, 2)), int(rng.integers(0, 2))
        seed = int(rng.integers(1 << 30))
        res = []
        for f in (kld_sample, kld_one_at_a_time):
            occ = np.zeros(kld_bins(area, kp), dtype=np.uint8)
            out = np.full((3, nmax), np.nan)
            s = state_from_seed(np.random.SeedSequence(seed))
            m, inj = f(P, cum, n, u, motion, mnoise, area, kp, nmax, occ,
                       np.empty(nmax, dtype=np.int64), prob, inj_sensor, sensor, bc, 2, ids, zs,
                       0.2, 0.05, s, out)
            assert not occ.any()
            res.append((m, inj, out[:, :m].copy(), s.copy()))
        (m1, i1, o1, s1), (m2, i2, o2, s2) = res
        assert (m1, i1) == (m2, i2), case
        assert np.array_equal(o1, o2) and np.array_equal(s1, s2), case


def test_the_guided_search_counts_the_running_sums_up_to_a_position():
    # against numpy's searchsorted (side right) at the positions where rounding could bite:
    # each running sum and the doubles beside it, each guide cell's edge g acc / n and the
    # doubles beside it, over equal weights (running sums on the cell edges), peaked weights
    # and weights with zeros (repeated running sums)
    from pfbench.filters.mcl import guide_table, guided_upper_bound
    rng = np.random.default_rng(5)
    sets = [np.full(n, 1.0 / n) for n in (1, 3, 10, 1000)]
    sets += [np.full(64, 0.1), rng.random(500) ** 30, np.where(rng.random(400) < 0.5, 0.0, 1.0)]
    for w in sets:
        n = w.size
        cum = np.cumsum(w)
        guide = np.empty(n, dtype=np.int64)
        ginv = guide_table(cum, n, guide)
        acc = cum[-1]
        edges = np.arange(n) * (acc / n)
        v = np.concatenate([cum, edges, [0.0, acc, rng.random() * acc]])
        v = np.concatenate([v, np.nextafter(v, -np.inf), np.nextafter(v, np.inf)])
        v = v[(v >= 0) & (v <= acc)]
        got = np.array([guided_upper_bound(cum, n, guide, ginv, x) for x in v])
        assert np.array_equal(got, np.searchsorted(cum, v, side="right")), n


def test_kld_count_is_the_chi_square_quantile():
    from scipy.stats import chi2
    for eps, delta in ((0.05, 0.01), (0.15, 0.05)):
        z = NormalDist().inv_cdf(1 - delta)
        for k in (2, 5, 20, 100, 1000):
            exact = chi2.ppf(1 - delta, k - 1) / (2 * eps)
            # Wilson-Hilferty, rounded up: within 1% (+1) from 5 bins on, 20% for one degree of
            # freedom
            assert abs(kld_count(k, eps, z) - exact) <= 1 + (0.01 if k >= 5 else 0.2) * exact
    assert kld_count(1, 0.05, 2.0) == 0


def test_kld_draws_kld_min_from_one_bin_and_more_the_more_bins_are_occupied():
    kp = KldParams(0.05, NormalDist().inv_cdf(0.99), 0.5, math.radians(10.0), 40.0)
    one = np.tile([10.2, 20.3, 0.1], (30, 1))
    m, moved, area = _kld_draw(one, kp)
    assert m == 40                                            # one bin: n_min
    counts = []
    for k in (2, 5, 20, 60):
        # k particles in k different bins (0.5 m apart along x), equal weights, no motion noise
        P = np.column_stack([0.25 + 0.5 * np.arange(k), np.full(k, 20.25), np.zeros(k)])
        m, moved, area = _kld_draw(P, kp, seed=k)
        bins = {kld_bin(*p, area, kp) for p in moved}
        assert len(bins) == k
        assert m == max(40, kld_count(k, kp[0], kp[1])), k
        counts.append(m)
    assert counts == sorted(counts) and counts[-1] > 40
    # motion noise spreads one pose over more bins: more particles
    m_noisy, moved, _ = _kld_draw(one, kp, noise=1.0)
    assert m_noisy > 40 and m_noisy == max(40, kld_count(
        len({kld_bin(*p, area, kp) for p in moved}), kp[0], kp[1]))


def test_kld_mcl_shrinks_its_set_as_it_localizes():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=60)
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(30)))
    out = _mcl(model, data, 5000, sampling="kld", kld_min=50)
    err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
    assert err[-10:].max() < 0.5
    assert out["n"][0] == 5000 and out["n"][-10:].max() < 1000
    assert out["resampled"].all() and out["n"].min() >= 50


def test_kld_with_sensor_resetting_is_a_config_error(tmp_path):
    from pfbench.config import load
    from pfbench.schema import ConfigError
    cfg = tmp_path / "k.yaml"
    cfg.write_text(f"name: k\nscenario:\n  name: beacon_field\n  world: "
                   f"{ROOT / 'configs/worlds/beacon_field.yaml'}\nfilters:\n  mcl:\n"
                   "    particles: 100\n    sampling: kld\n    reset: srl\n")
    with pytest.raises(ConfigError, match=r"k.yaml:9: filters.mcl.reset: KLD-sampling"):
        load(cfg)


from pfbench.filters.sspf_field import PoseStd, chol, chol_solve, lognormal3, transition_cov  # noqa: E402


def _ukf_reference(x, P, u, sd, jit, Wm, Wc, sq, bc, ids, zs, sr, sb):
    """The augmented UKF of one particle in numpy: sigma points of [pose, odometry noise], the
    motion, the circular mean heading, the range-bearing sensor and the update."""
    wrap_ = lambda a: (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi
    try:
        L = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        L = np.diag([jit[0], jit[0], jit[1]])
    pts = [(x.copy(), np.zeros(3))]
    for sgn in (1.0, -1.0):
        for k in range(6):
            px, w = x.copy(), np.zeros(3)
            if k < 3:
                px = px + sgn * sq * L[:, k]
            else:
                w[k - 3] = sgn * sq * sd[k - 3]
            pts.append((px, w))
    Y = np.array([[p[0] + (u[1] + w[1]) * np.cos(p[2] + u[0] + w[0]),
                   p[1] + (u[1] + w[1]) * np.sin(p[2] + u[0] + w[0]),
                   wrap_(p[2] + u[0] + w[0] + u[2] + w[2])] for p, w in pts])
    xm = np.array([Wm @ Y[:, 0], Wm @ Y[:, 1], wrap_(Y[0, 2] + Wm @ wrap_(Y[:, 2] - Y[0, 2]))])
    D = Y - xm
    D[:, 2] = wrap_(D[:, 2])
    Pm = (Wc[:, None, None] * D[:, :, None] * D[:, None, :]).sum(0) + np.diag(
        [jit[0] ** 2, jit[0] ** 2, jit[1] ** 2])
    Z = np.column_stack([f(j) for j in ids for f in (
        lambda j: np.hypot(bc[j, 0] - Y[:, 0], bc[j, 1] - Y[:, 1]),
        lambda j: wrap_(np.arctan2(bc[j, 1] - Y[:, 1], bc[j, 0] - Y[:, 0]) - Y[:, 2]))])
    isb = np.arange(Z.shape[1]) % 2 == 1
    zm = np.where(isb, wrap_(Z[0] + Wm @ wrap_(Z - Z[0])), Wm @ Z)
    DZ = Z - zm
    DZ[:, isb] = wrap_(DZ[:, isb])
    S = (Wc[:, None, None] * DZ[:, :, None] * DZ[:, None, :]).sum(0) + np.diag(
        np.where(isb, sb * sb, sr * sr))
    C = (Wc[:, None, None] * D[:, :, None] * DZ[:, None, :]).sum(0)
    K = C @ np.linalg.inv(S)
    inn = zs.ravel() - zm
    inn[isb] = wrap_(inn[isb])
    xn = xm + K @ inn
    xn[2] = wrap_(xn[2])
    Pn = Pm - K @ C.T
    return xn, 0.5 * (Pn + Pn.T)


def test_the_particles_ukfs_in_rows_are_each_particles_augmented_ukf():
    # the row passes against a numpy UKF per particle: spread poses (headings near +-pi, where
    # the sigma points wrap), covariances from tight to wide, and one that is not positive
    # definite (the jitter's factor instead); two range-bearing observations
    from pfbench.filters import sspf_field as sf
    from pfbench.filters.ukf import ut_weights
    rng = np.random.default_rng(8)
    c = 7
    pr, wk = sf.new_rows(c), sf.new_chunk_work(8, 12)
    pr.X[:] = np.array([rng.uniform(5, 35, c), rng.uniform(5, 35, c),
                        [3.1, -3.1, 0.0, 1.0, -2.0, 2.9, 0.5]])
    for p in range(c):
        A = rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-2, 0)
        pr.Pc[:, p] = (A @ A.T + 1e-4 * np.eye(3)).ravel()
    pr.Pc[:, 2] = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).ravel()
    Wm, Wc = np.empty(13), np.empty(13)
    sq = ut_weights(6, 0.9, 2.0, 0.0, Wm, Wc)
    u, sd, jit = np.array([0.1, 0.8, -0.05]), np.array([0.02, 0.1, 0.03]), sf.PoseStd(0.05, 0.02)
    bc = np.array([[4.0, 20.0], [14.0, 3.0], [30.0, 6.0]])
    ids = np.array([0, 2], dtype=np.int64)
    zs = np.array([[18.0, 0.7], [9.0, -2.5]])
    o = sf.FieldOptions(1, 1, 0.3, 0.05, c, 2, 0.0, 3, 1)
    zobs, isb = np.empty(12), np.zeros(12, dtype=np.int64)
    nz = sf.observation_vector(zs, 2, o, zobs, isb)
    sf.predict_moments(pr, 0, c, u, sq, sd, jit, wk, Wm, Wc)
    sf.sensor_update(bc, ids, zs, 2, nz, o, zobs, isb, wk, Wm, Wc, c)
    for p in range(c):
        xr, Pr = _ukf_reference(pr.X[:, p], pr.Pc[:, p].reshape(3, 3), u, sd, jit, Wm, Wc, sq,
                                bc, ids, zs, 0.3, 0.05)
        assert np.allclose(wk.xm[:, p], xr, rtol=1e-9, atol=1e-12), p
        assert np.allclose(wk.Pn[:, p].reshape(3, 3), Pr, rtol=1e-7, atol=1e-12), p


def test_sspf_linear_algebra_matches_numpy():
    from scipy.stats import multivariate_normal
    rng = np.random.default_rng(5)
    for n in (1, 3, 7, 12):
        A = rng.normal(size=(n, n))
        A = A @ A.T + n * np.eye(n)
        L = np.zeros((n, n))
        assert chol(A, n, L)
        assert np.allclose(L, np.linalg.cholesky(A))
        b = rng.normal(size=n)
        x = b.copy()
        chol_solve(L, n, x)
        assert np.allclose(A @ x, b)
    assert not chol(np.array([[1.0, 2.0], [2.0, 1.0]]), 2, np.zeros((2, 2)))
    Q = np.empty((3, 3))
    transition_cov(1.0, 2.0, 0.3, np.array([0.1, 0.5, 0.05]), np.array([0.01, 0.05, 0.03]),
                   PoseStd(0.02, 0.01), Q)
    L = np.zeros((3, 3))
    assert chol(Q, 3, L)
    d = np.array([0.03, -0.02, 0.01])
    assert lognormal3(*d, L) == pytest.approx(multivariate_normal(np.zeros(3), Q).logpdf(d))


def test_sspf_localizes_from_a_uniform_start_with_one_range_a_step():
    # sspf2008's setting: one beacon answers per step; the UKF proposal moves each particle toward
    # the range circle. 6 trials of 1000 particles: within 0.5 m at the end in at least 5.
    model = _field(steps=80)
    ft = FILTERS["sspf_field"]
    p = Params({k: v.default for k, v in ft.schema.items()})
    ok = 0
    for trial in range(6):
        truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(100 + trial)))
        out = ft.run(model, data, p, 1000, state_from_seed(np.random.SeedSequence(trial)))
        err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
        ok += err[-1] < 0.5
        acc = out["mh_accept"][out["resampled"] == 1]
        assert np.all((acc >= 0) & (acc <= 1))
    assert ok >= 5


def test_type_sspf_on_the_beacon_field_is_the_localization_sspf(tmp_path):
    from pfbench.config import load
    cfg = tmp_path / "s.yaml"
    cfg.write_text(f"name: s\nscenario:\n  name: beacon_field\n  world: "
                   f"{ROOT / 'configs/worlds/beacon_field.yaml'}\nfilters:\n  sspf:\n"
                   "    particles: 100\n    jitter_m: 0.1\n")
    run = load(cfg).filters[0]
    assert run.type == "sspf_field" and run.params["jitter_m"] == 0.1


@pytest.mark.parametrize("name,over", [("mcl", {}), ("mcl", {"sampling": "kld"}),
                                       ("sspf_field", {})])
def test_snapshots_leave_the_run_unchanged_and_hold_its_particles(name, over):
    model = _field(steps=20)
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(7)))
    ft = FILTERS[name]
    p = Params({**{k: v.default for k, v in ft.schema.items()}, **over})
    a = ft.run(model, data, p, 300, state_from_seed(np.random.SeedSequence(1)))
    b = ft.run(model, data, p, 300, state_from_seed(np.random.SeedSequence(1)),
               snapshots=(0, 20, 5))
    assert np.array_equal(a["pose"], b["pose"])
    steps, parts, counts = b["snapshots"]
    assert list(steps) == [0, 5, 20]
    assert counts[0] == 300 and list(counts[1:]) == [b["n"][4], b["n"][19]]
    # the initial cloud covers the field; the estimate at a step is its particles' weighted mean,
    # so it lies within their bounding box
    assert parts[0, :, 0].min() < 2 and parts[0, :, 0].max() > 38
    for k, t in enumerate(steps[1:], start=1):
        P = parts[k, :counts[k]]
        assert np.all(P.min(axis=0)[:2] <= b["pose"][t, :2] + 1e-9)
        assert np.all(P.max(axis=0)[:2] >= b["pose"][t, :2] - 1e-9)


def test_a_known_start_tracks_and_plain_mcl_does_not_survive_a_kidnapping():
    model = _field(sensor="range_bearing", steps=60, initial="known", kidnap_steps=[30],
                   kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(40)))
    out = _mcl(model, data, 500)
    err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
    assert err[0] < 0.1 and err[1:30].max() < 0.5       # tracks from the first step
    assert err[31:].min() > 2.0                         # and stays lost after the kidnapping
    m = localization_metrics(truth.pose, out, 0.5, model.kidnaps)
    assert m["converge_step"] == 1 and m["recovery_failures"] == 1


def test_partial_sums_cover_every_element():
    """MCL's partial sums (four lanes and a tail) add every element once, for every length."""
    from pfbench.filters.weights import lane_sum as _lanesum
    rng = np.random.default_rng(4)
    for n in range(0, 23):
        a = rng.integers(-50, 50, n + 3).astype(float)      # integers: exact in any order
        assert _lanesum(a, n) == a[:n].sum()
    x = rng.random(10_001)
    assert abs(_lanesum(x, x.size) - math.fsum(x)) <= 1e-12 * math.fsum(x)


@pytest.mark.parametrize("motion,sensor,resampling,resample", [
    ("odometry", "range", "systematic", "always"),
    ("rot_trans_rot", "range_bearing", "systematic", "neff"),
    ("odometry", "range_bearing", "multinomial", "always"),
    ("rot_trans_rot", "range", "residual", "neff")])
def test_the_set_copied_while_drawing_is_the_gathered_set(motion, sensor, resampling, resample):
    """Plain MCL copies its resampled set while the next step draws its noise. Sensor resetting
    that never fires (threshold 0) gathers the set at once, and draws nothing more: the two runs
    must agree bit for bit, for either motion model, each scheme's ancestors, and resampling at
    every step or only on a low ESS."""
    model = _field(motion=motion, sensor=sensor, steps=40)
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(3)))
    over = {"resampling": resampling, "resample": resample, "neff_ratio": 0.6}
    plain = _mcl(model, data, 203, seed=5, **over)
    gathered = _mcl(model, data, 203, seed=5, reset="srl", srl_threshold=0.0, **over)
    assert gathered["injected"].sum() == 0
    assert 0 < plain["resampled"].sum() <= 40
    for key in ("pose", "ess", "resampled", "pmean", "n"):
        assert np.array_equal(plain[key], gathered[key]), key


def _lanes(terms, n):
    """A sum in four partial sums, element i in lane i % 4 and the tail past the last multiple
    of 4 in lane 0, added pairwise: what the kernel's lanes compute, in plain Python."""
    s = [0.0] * 4
    top = n - n % 4
    for i in range(n):
        s[i % 4 if i < top else 0] += terms[i]
    return (s[0] + s[1]) + (s[2] + s[3])


def test_the_summary_pass_is_its_sums():
    """``weighted_sums``: the weights' running sums in order (the last, S, their sum), the estimate
    (weighted means of x and y, sums over S; the heading's circular mean) and the ESS
    S^2 / sum W^2, each sum in four lanes, for every length; the weights are not touched and
    nothing past n is read or written. With whole numbers every product and sum is exact, so
    the lanes must give these sums to the bit whether or not a multiply-add is fused; with real
    numbers, to rounding."""
    from pfbench.filters.mcl import weighted_sums
    rng = np.random.default_rng(8)
    for whole in (True, False):
        for n in list(range(1, 13)) + [1001]:
            P = rng.integers(-40, 40, (3, n + 2)).astype(float)
            CS = rng.integers(-9, 9, (2, n + 2)).astype(float)
            W = rng.integers(1, 30, n + 2).astype(float)
            if not whole:
                P, CS, W = rng.normal(size=P.shape), rng.normal(size=CS.shape), rng.random(n + 2)
            W[n:] = np.nan
            before = W.copy()
            cum, out = np.full(n + 2, -1.0), np.empty(3)
            ess = weighted_sums(P, W, n, CS, cum, out)
            w = before[:n].tolist()
            acc, sums = 0.0, []
            for x in w:
                acc += x
                sums.append(acc)
            wx, wy, wc, ws = ([w[i] * R[i] for i in range(n)] for R in (P[0], P[1], CS[0], CS[1]))
            want = [_lanes(wx, n) / acc, _lanes(wy, n) / acc,
                    math.atan2(_lanes(ws, n), _lanes(wc, n)),
                    acc * acc / _lanes([x * x for x in w], n)]
            assert np.array_equal(W, before, equal_nan=True)
            assert cum[:n].tolist() == sums and (cum[n:] == -1.0).all()
            if whole:
                assert out.tolist() + [ess] == want, n
            else:
                assert np.allclose(out.tolist() + [ess], want, rtol=1e-13, atol=1e-13), n


def test_mcls_passes_are_public_and_keep_their_contracts():
    """loglik_pass, exp_pass and trig_pass (the passes the speed-limit bench times alone): the
    log-likelihood of pose_loglik for every particle (vecmath's arctangent: to rounding), the
    shifted exponentials, the headings' cosines and sines, on a part of the set [i0, i1)."""
    from pfbench.filters.mcl import exp_pass, loglik_pass, trig_pass
    from pfbench.models.beacons import loglik_const, pose_loglik

    rng = np.random.default_rng(5)
    N = 37
    P = np.ascontiguousarray(np.vstack([rng.uniform(0, 10, N), rng.uniform(0, 10, N),
                                        rng.uniform(-np.pi, np.pi, N)]))
    CS = np.full((2, N), 7.0)
    trig_pass(P, 3, 30, CS)
    assert np.allclose(CS[0, 3:30], np.cos(P[2, 3:30]), rtol=0, atol=1e-15)
    assert np.allclose(CS[1, 3:30], np.sin(P[2, 3:30]), rtol=0, atol=1e-15)
    assert (CS[:, :3] == 7.0).all() and (CS[:, 30:] == 7.0).all()
    bc = np.array([[1.0, 2.0], [8.0, 3.0], [5.0, 9.0]])
    ids = np.array([0, 2, 1], dtype=np.int64)
    zs = np.array([[3.0, 0.5], [4.0, -1.0], [6.0, 2.0]])
    for sensor in (0, 1):
        for m in (0, 1, 3):
            ll = np.full(N, np.nan)
            loglik_pass(P[0], P[1], P[2], N, bc, m, ids, zs, sensor, 0.3, 0.1,
                        loglik_const(m, sensor, 0.3, 0.1), ll)
            ref = [pose_loglik(P[0, i], P[1, i], P[2, i], bc, m, ids, zs, sensor, 0.3, 0.1)
                   for i in range(N)]
            assert np.allclose(ll, ref, rtol=1e-12, atol=1e-9), (sensor, m)
    a = rng.normal(size=N)
    out = np.empty(N)
    exp_pass(a, 0.5, N - 1, out)
    assert np.allclose(out[:N - 1], np.exp(a[:N - 1] - 0.5), rtol=1e-15, atol=0)


@pytest.mark.parametrize("bad", [1e200, math.nan])
def test_sspf_ignores_an_impossible_observation_and_recovers(bad):
    from dataclasses import replace
    # A range of 1e200 drags every particle's UKF proposal there: every log-weight is -inf or NaN
    # at that step, which then ignores its observations (particles from the transition density)
    model = _field(steps=40, initial="known")
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(41)))
    t0 = next(t for t in range(10, 40) if data.obs_n[t] > 0)
    z = np.array(data.obs_z, dtype=float)
    z[t0, :data.obs_n[t0], 0] = bad
    ft = FILTERS["sspf_field"]
    p = Params({k: v.default for k, v in ft.schema.items()})
    clean = ft.run(model, data, p, 300, state_from_seed(np.random.SeedSequence(2)))
    out = ft.run(model, replace(data, obs_z=z), p, 300, state_from_seed(np.random.SeedSequence(2)))
    assert clean["underflow_steps"] == 0 and out["underflow_steps"] == 1
    assert np.all(np.isfinite(out["pose"]))
    assert np.array_equal(out["pose"][:t0 + 1], clean["pose"][:t0 + 1])    # before: untouched
    err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
    err_clean = np.hypot(*(clean["pose"][:, :2] - truth.pose[:, :2]).T)
    assert err[t0 + 1] < 1.0                     # the step's estimate: the motion's prediction
    assert err[t0 + 6:].mean() < 1.2 * err_clean[t0 + 6:].mean() + 0.05
