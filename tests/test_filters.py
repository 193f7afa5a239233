"""Filters against the exact Kalman filter on a scalar linear-Gaussian model; underflow handling."""
import math

import numpy as np
import pytest

from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.rng import state_from_seed
from pfbench.scenarios import linear_gaussian, ungm
from pfbench.models.scalar import simulate

from .conftest import default_params

_params = default_params


def _linear(**over):
    return linear_gaussian.build(_params(linear_gaussian.SCHEMA, **over))


def _kalman(model, y):
    return FILTERS["kf"].run(model, y, Params({}), None, None)


def _numpy_kalman(y, a, c, Q, R, m, P):
    """The textbook recursion, written independently of the kernel."""
    ms, Ps = [m], [P]
    for t in range(1, y.size):
        m, P = a * m, a * a * P + Q
        K = P * c / (c * c * P + R)
        m, P = m + K * (y[t] - c * m), (1 - K * c) * P
        ms.append(m)
        Ps.append(P)
    return np.array(ms), np.array(Ps)


def test_kalman_kernel_matches_textbook_recursion():
    model = _linear(a=0.8, c=1.5, process_noise_var=0.7, measurement_noise_var=2.0, prior_var=3.0)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(5)))
    kf = _kalman(model, y)
    m, P = _numpy_kalman(y, 0.8, 1.5, 0.7, 2.0, 0.0, 3.0)
    assert np.allclose(kf["xhat"], m, rtol=0, atol=1e-13)
    assert np.allclose(kf["pvar"], P, rtol=0, atol=1e-13)


@pytest.mark.parametrize("augmented", [True, False])
@pytest.mark.parametrize("alpha,beta,kappa", [(1.0, 0.0, 2.0), (1.0, 2.0, 0.0), (0.5, 2.0, 1.0)])
@pytest.mark.parametrize("a,c,Q,R", [(0.9, 1.0, 1.0, 1.0), (1.05, 0.3, 0.1, 4.0),
                                     (-0.5, 2.0, 10.0, 0.01)])
def test_ukf_equals_kalman_on_linear_gaussian(augmented, alpha, beta, kappa, a, c, Q, R):
    model = _linear(a=a, c=c, process_noise_var=Q, measurement_noise_var=R, steps=80, prior_var=2.0)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(11)))
    kf = _kalman(model, y)
    params = _params(FILTERS["ukf"].schema, alpha=alpha, beta=beta, kappa=kappa,
                     augmented=augmented)
    uk = FILTERS["ukf"].run(model, y, params, None, None)
    scale = max(1.0, float(np.abs(kf["xhat"]).max()))
    assert np.max(np.abs(uk["xhat"] - kf["xhat"])) <= 1e-10 * scale
    assert np.max(np.abs(uk["pvar"] - kf["pvar"])) <= 1e-10 * max(1.0, float(kf["pvar"].max()))
    assert uk["variance_floor_steps"] == 0


def _pf(model, y, N, seed, **over):
    params = _params(FILTERS["pf"].schema, **over)
    return FILTERS["pf"].run(model, y, params, N, state_from_seed(np.random.SeedSequence(seed)))


@pytest.mark.parametrize("scheme", ["systematic", "multinomial", "stratified", "residual"])
def test_pf_converges_to_kalman_mean_as_N_grows(scheme):
    model = _linear(a=0.9, c=1.0, process_noise_var=1.0, measurement_noise_var=0.5, steps=40)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(21)))
    m = _kalman(model, y)["xhat"][1:]
    reps = 30

    def mse(N):
        return np.mean([np.mean((_pf(model, y, N, 100 * N + r, resampling=scheme)["xhat"][1:]
                                 - m) ** 2) for r in range(reps)])

    small, large = mse(100), mse(3200)
    # Monte Carlo error of the PF mean is O(1/N): 32x the particles should cut the squared error
    # by about 32x; demand at least 10x, and an absolute level well under the posterior variance.
    assert large < small / 10
    assert large < 0.01 * 0.4


def test_pf_is_unbiased_against_kalman_at_moderate_N():
    model = _linear(a=0.9, c=1.0, process_noise_var=1.0, measurement_noise_var=1.0, steps=20)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(3)))
    m = _kalman(model, y)["xhat"]
    errs = np.array([_pf(model, y, 500, r)["xhat"] - m for r in range(300)])[:, 1:]
    mean_err = errs.mean(axis=0)
    se = errs.std(axis=0, ddof=1) / math.sqrt(errs.shape[0])
    # the bias of a PF is O(1/N); at N = 500 it is far below 5 standard errors of 300 runs
    assert np.all(np.abs(mean_err) < 5 * se)


def test_neff_trigger_resamples_less_and_estimates_stay_close():
    model = _linear(steps=60)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(4)))
    m = _kalman(model, y)["xhat"]
    always = _pf(model, y, 2000, 1)
    neff = _pf(model, y, 2000, 1, resample="neff", neff_ratio=0.5)
    assert always["resampled"][1:].sum() == 60
    assert 0 < neff["resampled"][1:].sum() < 60
    assert np.all(neff["ess"][1:][neff["resampled"][1:] == 1] < 1000)
    assert np.sqrt(np.mean((neff["xhat"] - m) ** 2)) < 0.1


def test_estimate_after_resampling_is_the_plain_mean():
    model = _linear(steps=10)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(4)))
    before = _pf(model, y, 1000, 9)
    after = _pf(model, y, 1000, 9, estimate="after_resampling")
    # same seed, same particles: the two estimates differ only by resampling noise
    assert not np.array_equal(before["xhat"], after["xhat"])
    assert np.max(np.abs(before["xhat"] - after["xhat"])) < 0.2


def test_measurement_far_outside_every_particle_gives_finite_estimates():
    # exp(-0.5 d^2 / R) underflows to 0 for every particle when d ~ 1e4; the log-domain max shift
    # must keep the estimate finite (no NaN), with no underflow event (log-weights stay finite).
    model = ungm.build(_params(ungm.SCHEMA, steps=5))
    y = np.array([0.0, 1e4, 1e4, 0.5, 1.0, 2.0])
    out = _pf(model, y, 200, 0)
    assert np.all(np.isfinite(out["xhat"]))
    assert out["underflow_steps"] == 0


def test_every_log_weight_nan_is_an_event_not_a_nan_estimate():
    model = ungm.build(_params(ungm.SCHEMA, steps=4))
    y = np.array([0.0, 1.0, np.nan, 2.0, 1.0])   # a NaN measurement: every log-weight is NaN
    out = _pf(model, y, 100, 0, resample="neff")
    assert out["underflow_steps"] == 1
    assert np.all(np.isfinite(out["xhat"]))
    assert np.all(np.isfinite(out["ess"]))


def test_diversity_diagnostics():
    model = _linear(steps=30)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(4)))
    out = _pf(model, y, 500, 2)
    d = out["distinct"][1:]
    assert np.all((d > 0) & (d <= 1))
    assert np.all(out["div_l1"][1:] > 0)
    # the mean absolute difference of N(0, s^2) samples is 2 s / sqrt(pi); posterior sd ~ 0.7 here
    assert np.all(out["div_l1"][1:] < 3.0)


def test_mean_abs_pairwise_matches_brute_force():
    from pfbench.filters._common import mean_abs_pairwise
    x = np.random.default_rng(0).normal(size=57)
    brute = np.mean([abs(a - b) for i, a in enumerate(x) for b in x[i + 1:]])
    assert math.isclose(mean_abs_pairwise(x), brute, rel_tol=1e-12)


def test_particles_with_nan_likelihood_get_zero_weight_without_an_event():
    # An observation model that is NaN for x > 0: those particles must weigh nothing, the rest
    # carry the estimate, and the step is not an underflow event.
    from numba import njit

    from pfbench.models.scalar import MODEL_SIG, ScalarModel

    @njit(MODEL_SIG)
    def nan_above_zero(x, t, theta, out):
        for i in range(x.size):
            out[i] = np.nan if x[i] > 0.0 else x[i]

    base = _linear(steps=3, prior_var=4.0)
    model = ScalarModel(base.transition, nan_above_zero, base.theta, base.noise, 0.0, 0.0, 4.0, 3)
    y = np.array([0.0, -1.0, -1.0, -1.0])
    out = _pf(model, y, 400, 5, resample="neff", neff_ratio=0.01)
    assert out["underflow_steps"] == 0
    assert np.all(np.isfinite(out["xhat"]))
    assert np.all(out["xhat"][1:] < 0)          # only particles at x <= 0 carry weight
    assert np.all(out["ess"][1:] < 400)


def test_model_functions_are_handed_over_by_address_and_stay_the_functions():
    """A model holds its functions as ModelFunction (the compiled entry's address, looked up once):
    from a plain @njit function or a lazily built kernel alike; it calls from Python like the
    function, pickles back to it (the Dask engine ships models), and a filter gives the same
    trial with it as with the plain dispatcher."""
    import pickle

    from numba import njit, typeof

    from pfbench.filters.pf import pf_kernel
    from pfbench.models.scalar import MODEL_SIG, ModelFn, ModelFunction, ScalarModel
    from pfbench.scenarios import ungm

    @njit(MODEL_SIG)
    def double(x, t, theta, out):
        for i in range(x.size):
            out[i] = 2.0 * x[i]

    base = _linear(steps=3)
    model = ScalarModel(double, base.observe, base.theta, base.noise, 0.0, 0.0, 1.0, 3)
    assert isinstance(model.transition, ModelFunction)
    assert isinstance(model.observe, ModelFunction)
    assert typeof(model.transition) == ModelFn
    out = np.empty(2)
    model.transition(np.array([1.0, -3.0]), 1.0, base.theta, out)
    assert out.tolist() == [2.0, -6.0]
    again = pickle.loads(pickle.dumps(model.transition))
    assert isinstance(again, ModelFunction) and again.address == model.transition.address
    assert ScalarModel(model.transition, model.observe, base.theta, base.noise, 0.0, 0.0, 1.0,
                       3).transition is model.transition

    m = ungm.build({k: key.default for k, key in ungm.SCHEMA.items()})
    y = np.linspace(-2.0, 3.0, 21)

    def trial(f, h):
        T1 = y.size
        xhat, ess, d1, d2, d3 = (np.empty(T1) for _ in range(5))
        res = np.empty(T1, dtype=np.int64)
        pf_kernel(f, h, *m.likelihood(), m.theta, m.noise, y, m.prior_mean, m.prior_var, 300, 1,
                  np.inf, 0, 0, -np.inf, 0, np.random.SeedSequence(3).generate_state(4, np.uint64),
                  xhat, ess, res, d1, d2, d3)
        return xhat

    assert np.array_equal(trial(m.transition, m.observe),
                          trial(m.transition.dispatcher, m.observe.dispatcher))


def test_kalman_family_reports_its_innovations_and_their_variances():
    """kf, ekf and ukf give the innovation y_t - yhat_t and its predicted variance S_t (the NIS);
    on linear_gaussian the three agree with the textbook recursion's."""
    a, c, Q, R = 0.8, 1.5, 0.7, 2.0
    model = _linear(a=a, c=c, process_noise_var=Q, measurement_noise_var=R, prior_var=3.0)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(8)))
    m, P = _numpy_kalman(y, a, c, Q, R, 0.0, 3.0)
    Pp = a * a * P[:-1] + Q
    S = c * c * Pp + R
    nu = y[1:] - c * a * m[:-1]
    runs = {"kf": _kalman(model, y)}
    for name in ("ekf", "ukf"):
        runs[name] = FILTERS[name].run(model, y, _params(FILTERS[name].schema), None, None)
    for name, out in runs.items():
        assert FILTERS[name].reports == ("nees", "nis")
        assert np.isnan(out["innov"][0]) and np.isnan(out["innov_var"][0])
        assert np.allclose(out["innov"][1:], nu, rtol=0, atol=1e-10), name
        assert np.allclose(out["innov_var"][1:], S, rtol=1e-10, atol=0), name
