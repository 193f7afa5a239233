"""Numerical traps in the kernels: weights of any finite magnitude, KLD-sampling's bound, quantile
and histogram at extreme settings, and divisions by zero on the trial path (all -inf
log-weights, states that overflow). No input that passes validation may give a wrong number, a
traceback, a hang or a write out of bounds."""
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.resampling import SCHEMES, ancestors, resample, SCHEME_CODES
from pfbench.rng import state_from_seed

ALL = list(SCHEMES)


def _state(seed=0):
    return state_from_seed(np.random.SeedSequence(seed))


def _draw(w, scheme, seed):
    """(ancestors, the generator's state after) of w under scheme."""
    s = _state(seed)
    return ancestors(w, scheme, s).tolist(), s.tolist()


# ---------------------------------------------------------------- resampling at any magnitude

_base = st.lists(st.one_of(st.just(0.0), st.floats(2.0 ** -60, 1.0)), min_size=1, max_size=60)


@settings(max_examples=150, deadline=None)
@given(_base, st.integers(-962, 1023), st.sampled_from(ALL), st.integers(0, 2**32 - 1))
@example([1.0] * 12, 1022, "systematic", 0)        # twelve weights near 3.1e307: the sum overflows
@example([0.5, 1.0, 0.25], -962, "residual", 1)
def test_ancestors_do_not_depend_on_the_scale_of_the_weights(base, k, scheme, seed):
    """Weights scaled by 2^k (exactly: every weight stays normal) have the ancestors of the
    unscaled weights, and draw the same from the generator, at every scale: sums past the
    largest double and totals near the subnormals included."""
    w = np.array(base)
    if not (w > 0).any():
        w[0] = 1.0
    scaled = np.ldexp(w, k)
    assert np.array_equal(np.ldexp(scaled, -k), w)      # the scaling is exact
    assert _draw(scaled, scheme, seed) == _draw(w, scheme, seed)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 2**20), min_size=1, max_size=200), st.sampled_from(ALL),
       st.integers(0, 2**32 - 1))
def test_subnormal_weights_are_the_same_weights_at_an_ordinary_scale(m, scheme, seed):
    """Weights that are multiples of the smallest subnormal (2^-1074) resample as the integers
    they are multiples of."""
    m = np.array(m, dtype=float)
    if not (m > 0).any():
        m[-1] = 1.0
    assert _draw(np.ldexp(m, -1074), scheme, seed) == _draw(m, scheme, seed)


@pytest.mark.parametrize("scheme", ALL)
def test_the_overflowing_sum_and_many_subnormals_resample_correctly(scheme):
    """Twelve weights of 3.1e307 (their sum is inf) keep each particle once under the
    deterministic-spacing schemes and never collapse onto one; 3e5 subnormal weights resample
    as equal weights (and in linear time: the draw finishes)."""
    idx = ancestors(np.full(12, 3.1e307), scheme, _state(1))
    if scheme in ("systematic", "stratified", "residual"):
        assert sorted(idx.tolist()) == list(range(12))
    assert len(set(idx.tolist())) > 1
    N = 300_000
    assert _draw(np.full(N, 5e-320), scheme, 2) == _draw(np.ones(N), scheme, 2)


@pytest.mark.parametrize("bad, what", [
    ([1.0, -1.0], "non-negative"), ([1.0, math.nan], "finite"), ([1.0, math.inf], "finite"),
    ([0.0, 0.0], "positive sum"), ([], "non-empty"), ([[1.0]], "1-D"), (["a"], "numbers")])
def test_the_python_entry_refuses_weights_it_cannot_resample(bad, what):
    with pytest.raises(ValueError, match=what):
        ancestors(np.array(bad, dtype=object) if bad == ["a"] else np.array(bad, dtype=float),
                  "systematic", _state())


def test_the_python_entry_refuses_an_unknown_scheme_and_a_bad_state():
    with pytest.raises(ValueError, match="unknown resampling scheme 'sytematic'"):
        ancestors([1.0, 2.0], "sytematic", _state())
    for state in (np.zeros(3, dtype=np.uint64), np.zeros(4), [1, 2, 3, 4]):
        with pytest.raises(ValueError, match="uint64 array of 4"):
            ancestors([1.0, 2.0], "systematic", state)


@settings(max_examples=60, deadline=None)
@given(_base, st.integers(-962, 1023), st.integers(0, 1), st.integers(0, 2))
@example([1.0] * 12, 1022, 0, 0)
def test_the_stepwise_ewa_plan_does_not_depend_on_the_scale_of_the_weights(base, k, printed,
                                                                             copies):
    """ifa2021's stepwise EWA plan of weights scaled by 2^k is the plan of the weights (it kept
    one particle and mutated the rest when their sum overflowed), under every reading of its
    copies."""
    from pfbench.resampling import stepwise_ewa_plan
    w = np.array(base)
    if not (w > 0).any():
        w[0] = 1.0

    def plan(v):
        src, mut = np.empty(v.size, dtype=np.int64), np.empty(v.size, dtype=np.int8)
        kept = stepwise_ewa_plan(v, 0.9, printed, copies, src, mut)
        return kept, src.tolist(), mut.tolist()
    assert plan(np.ldexp(w, k)) == plan(w)


@pytest.mark.parametrize("scheme", ALL)
def test_kernels_stay_in_bounds_on_weights_the_entry_refuses(scheme):
    """The kernels (what the built-in filters call) never index out of [0, N): an infinite
    weight is picked over every finite one, a zero total resamples uniformly, NaN counts as 0."""
    code = SCHEME_CODES[scheme]
    idx = np.empty(6, dtype=np.int64)
    w = np.array([1.0, np.inf, 2.0, np.inf, 0.0, 1.0])
    resample(code, w, np.inf, _state(3), idx)
    assert set(idx.tolist()) <= {1, 3}
    w = np.zeros(6)
    resample(code, w, 0.0, _state(3), idx)
    assert idx.min() >= 0 and idx.max() < 6
    w = np.array([np.nan, 1.0, np.nan, 1.0, np.nan, np.nan])
    resample(code, w, np.nan, _state(3), idx)
    assert set(idx.tolist()) <= {1, 3}


# ---------------------------------------------------------------- KLD-sampling's bound

def test_kld_count_is_monotone_and_saturates_in_epsilon():
    """A smaller epsilon never asks for fewer particles: the count rises to KLD_COUNT_MAX and
    stays there (it wrapped to a negative integer at 1e-40 and drew kld_min)."""
    from pfbench.filters.mcl import KLD_COUNT_MAX, kld_count
    eps = np.logspace(300, -323, 400)
    for k in (2, 3, 10, 1000, 10**6):
        for z in (-8.2, 0.0, 2.33, 8.6, 38.5):
            c = [kld_count(k, e, z) for e in eps]
            assert all(0 <= x <= KLD_COUNT_MAX for x in c)
            assert all(a <= b for a, b in zip(c, c[1:])), (k, z)
    assert kld_count(10, 1e-40, 2.33) == KLD_COUNT_MAX
    assert kld_count(10, 5e-324, 2.33) == KLD_COUNT_MAX


def test_kld_quantile_for_any_delta():
    """z_(1-delta) for every delta in (0, 1): no StatisticsError where 1 - delta rounds to 1,
    rising as delta falls, the usual quantile at ordinary values."""
    from statistics import NormalDist

    from pfbench.filters.mcl import kld_quantile
    assert kld_quantile(0.01) == NormalDist().inv_cdf(0.99)
    deltas = sorted({*np.logspace(-323, -0.0001, 500), 3e-18, 5e-324, 2.0 ** -20, 0.5,
                     1 - 2.0 ** -53})
    z = [kld_quantile(float(d)) for d in deltas]
    assert all(math.isfinite(v) for v in z)
    assert all(a >= b for a, b in zip(z, z[1:]))
    assert kld_quantile(3e-18) > kld_quantile(1e-15) > 7.9


def _kld_draw(kp, nmax=2000, seed=0, noise=0.5):
    """KLD-sampling from 50 poses spread over a 40 m field; returns (count, drawn poses)."""
    from pfbench.filters.mcl import kld_bins, kld_sample
    from pfbench.models.odometry import MotionNoise
    area = np.array([40.0, 40.0])
    rng = np.random.default_rng(seed)
    P = np.column_stack([rng.uniform(0, 40, 50), rng.uniform(0, 40, 50),
                         rng.uniform(-math.pi, math.pi, 50)])
    n = P.shape[0]
    cum = np.cumsum(np.full(n, 1.0 / n))
    occ = np.zeros(kld_bins(area, kp), dtype=np.uint8)
    out = np.empty((3, nmax))
    m, _ = kld_sample(np.ascontiguousarray(P.T), cum, n, np.zeros(3), 0,
                      MotionNoise.additive(noise, 0.0), area, kp, nmax, occ,
                      np.empty(nmax, dtype=np.int64), 0.0, 0, 0, np.zeros((1, 2)), 0,
                      np.zeros(1, dtype=np.int64), np.zeros((1, 2)), 0.1, 0.1, _state(seed),
                      out)
    assert not occ.any()
    return m, out[:, :m].T


def _cells(poses, bm, br, area=40.0):
    """The distinct histogram cells of poses (exact for power-of-two bin sizes: x / bm is)."""
    nx = math.ceil(area / bm)
    nt = math.ceil(2 * math.pi / br)
    out = set()
    for x, y, th in poses:
        ix = min(max(math.floor(x / bm), 0), nx - 1)
        iy = min(max(math.floor(y / bm), 0), nx - 1)
        it = min(max(math.floor((th + math.pi) / br), 0), nt - 1)
        out.add((ix, iy, it))
    return len(out)


@pytest.mark.parametrize("bm", [2.0 ** -31, 2.0 ** -4, 0.5])
def test_kld_counts_the_bins_of_any_histogram(bm):
    """Bins of 2^-31 m x 5 deg (a grid of 2^72 bins: its index overflowed, and the kernel wrote
    out of bounds) are counted exactly, as ordinary ones are: the draw stops at the bound of the
    bins its particles occupy."""
    from pfbench.filters.mcl import KldParams, kld_count
    br = math.radians(5.0)
    z = 2.33
    kp = KldParams(0.5, z, bm, br, 10.0)
    m, poses = _kld_draw(kp)
    k = _cells(poses, bm, br)
    assert m == max(10, kld_count(k, 0.5, z)) or m == 2000
    # the particle before the last had not reached the bound of the bins before it
    assert m - 1 < max(10, kld_count(_cells(poses[:-1], bm, br), 0.5, z))


@pytest.mark.parametrize("bm, deg", [(1e-300, 1e-300), (5e-324, 5e-324), (1e300, 360.0)])
def test_kld_with_extreme_bins_runs_to_its_bound(bm, deg):
    """Bins so fine that every drawn particle lies in one of its own take the most particles;
    one bin for the whole field takes kld_min."""
    from pfbench.filters.mcl import KldParams
    kp = KldParams(0.05, 2.33, bm, math.radians(deg), 10.0)
    m, _ = _kld_draw(kp, nmax=500)
    assert m == (10 if bm > 1 else 500)


def _beacon_run(steps=8, **params):
    from pfbench.scenarios import beacon_field as bf

    from .conftest import ROOT
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(steps=steps, sensor="range_bearing")
    model = bf.build(bf.resolve(p, ROOT / "configs"))
    data, truth = bf.simulate(model, _state(4))
    ft = FILTERS["mcl"]
    q = {k: v.default for k, v in ft.schema.items()}
    q.update(sampling="kld", **params)
    return ft.run(model, data, Params(q), 1500, _state(5))


def test_kld_mcl_draws_more_for_a_smaller_epsilon_and_runs_at_any_delta():
    """eps 1e-40 draws at least what 1e-3 draws (it drew 50 where 1e-3 drew 240); delta 3e-18
    runs (the normal quantile of 1 - delta raised StatisticsError)."""
    loose = _beacon_run(kld_epsilon=1e-3)["n"]
    tight = _beacon_run(kld_epsilon=1e-40)["n"]
    # the first step draws from the same uniform cloud with the same generator: the bins its
    # particles fill ask for the most (a later step may put every draw into one bin: kld_min)
    assert tight[0] == 1500 >= loose[0] and tight.mean() >= loose.mean()
    out = _beacon_run(kld_delta=3e-18)
    assert (out["n"] >= 50).all()


def test_the_memory_estimate_counts_the_kld_histogram():
    """KLD-sampling's histogram (a byte a bin, up to 2^22 bins, or a hash set past that) is part
    of the estimate: a KLD run needs more than the same run at a fixed count."""
    from pfbench.config import validate
    from pfbench.resources import estimate

    from .conftest import ROOT
    cfg = {"scenario": {"name": "beacon_field", "steps": 10,
                        "world": str(ROOT / "configs/worlds/beacon_field.yaml")},
           "filters": {"mcl": {"particles": 100}}}
    kld = {**cfg, "filters": {"mcl": {"particles": 100, "sampling": "kld"}}}
    assert estimate(validate(kld)).bytes - estimate(validate(cfg)).bytes >= 2**20


# ---------------------------------------------------------------- divisions by zero in trials

def _run_config(cfg):
    from pfbench.api import run_experiment
    return run_experiment(cfg).trials


def test_an_explosive_linear_model_gives_diverged_steps_not_a_traceback():
    """a = 1.45 over 1100 steps: the states overflow; every filter finishes and reports the
    steps it lost (ZeroDivisionError from the UKF before)."""
    rows = _run_config({"seed": 1, "trials": 1,
                        "scenario": {"name": "linear_gaussian", "a": 1.45, "steps": 1100},
                        "filters": {"kf": {}, "pf": {"particles": 20}, "ukf": {}, "ekf": {}}})
    assert len(rows) == 4
    for _, r in rows.iterrows():
        assert r["diverged_steps"] > 0 or math.isfinite(r["rmse"]), r["filter"]


def test_slam_whose_log_weights_are_all_minus_infinity_counts_the_steps():
    """Range noise 5e-168 (its variance underflows to 0): every log-weight -inf or NaN; FastSLAM
    counts the steps as underflow steps and goes on, as MCL does (ZeroDivisionError before)."""
    from .conftest import ROOT
    rows = _run_config({"seed": 1, "trials": 1,
                        "scenario": {"name": "waypoint_course", "steps": 200,
                                     "world": str(ROOT / "configs/worlds/ifa_course.yaml"),
                                     "range_noise_m": 5e-168},
                        "filters": {"fastslam": {"particles": 10}}})
    assert rows["underflow_steps"].iloc[0] > 0


# ---------------------------------------------------------------- every filter x scenario

def _noise_keys(schema) -> list[str]:
    return [k for k, key in schema.items() if key.kind == "float" and
            ("noise" in k or k.endswith("_var")) and k != "prior_var"]


def _trap_configs():
    """(id, config, particles) for every built-in scenario and trap: one step at two particles
    (the fewest), noise levels of 1e-150 and 1e150 (every noise key at once), no noise (zero
    where allowed, else 5e-324), a prior variance of 1e300, 3000 steps."""
    from pfbench.scenarios import BUILTIN

    from .conftest import ROOT
    for name, scen in sorted(BUILTIN.items()):
        base = {"name": name}
        world = scen.SCHEMA.get("world")
        if world is not None:
            base["world"] = str(ROOT / "configs" / world.default)
        if "data_dir" in scen.SCHEMA:       # recorded data: Plaza-like files written by the test
            base.update(data_dir=DATA, verify_digest=False)

        def steps(n, schema=scen.SCHEMA):
            """n steps; of a scenario cut into steps of a time span, a span of n steps (at
            least two: a span must be longer than one step)."""
            if "steps" in schema or "step_s" not in schema:
                return {"steps": n}
            return {"end_s": max(n, 2) * schema["step_s"].default}
        noise = _noise_keys(scen.SCHEMA)
        yield f"{name}-one-step", {**base, **steps(1)}, 2
        yield f"{name}-tiny-noise", {**base, **steps(40), **{k: 1e-150 for k in noise}}, 20
        yield f"{name}-huge-noise", {**base, **steps(40), **{k: 1e150 for k in noise}}, 20
        # zero where a key allows it, else the smallest double (its square is 0)
        least = {k: 0.0 if scen.SCHEMA[k].min == 0.0 and not scen.SCHEMA[k].min_exclusive
                 else 5e-324 for k in noise}
        yield f"{name}-no-noise", {**base, **steps(40), **least}, 20
        if "prior_var" in scen.SCHEMA:
            yield f"{name}-huge-prior", {**base, **steps(40), "prior_var": 1e300}, 20
        yield f"{name}-long", {**base, **steps(3000)}, 5


# the data folder of a recorded-data scenario's traps, replaced by the recorded_data fixture's
DATA = "<recorded data>"


@pytest.fixture(scope="module")
def recorded_data(tmp_path_factory):
    """Plaza-like data files (tests/test_plaza.py), long enough for the longest trap (3000
    steps of 0.2 s)."""
    from .test_plaza import _plaza_like
    folder = tmp_path_factory.mktemp("recorded")
    _plaza_like(folder / "Plaza1_.mat", 1, seconds=620.0)
    _plaza_like(folder / "Plaza2_.mat", 2, heading_off=math.pi, seconds=620.0)
    return str(folder)


@pytest.mark.slow
@pytest.mark.parametrize("trap", list(_trap_configs()), ids=lambda t: t[0])
def test_every_filter_on_every_scenario_survives_numerical_traps(trap, recorded_data):
    """No exception, and every row's error finite or its lost steps counted: for every filter
    that runs on the scenario, at two particles and one step, at noise levels of 1e-150 and
    1e150, and over a long run."""
    from pfbench.api import run_experiment
    from pfbench.errors import UserError
    from pfbench.scenarios import BUILTIN
    _, scen, particles = trap
    if scen.get("data_dir") == DATA:
        scen = {**scen, "data_dir": recorded_data}
    kind = BUILTIN[scen["name"]].KIND
    filters = {}
    for fname, ft in FILTERS.items():
        if ft.runs_on(scen["name"], kind) and ft.run.__module__.startswith("pfbench."):
            filters[fname] = {"type": fname, **({"particles": particles} if ft.particles else {})}
    if not filters:
        pytest.skip("no filter runs on it")
    cfg = {"seed": 7, "trials": 1, "scenario": scen, "filters": filters}
    try:
        rows = run_experiment(cfg).trials
    except UserError as exc:           # a pairing the config refuses (one line, exit 2)
        pytest.skip(str(exc))
    for _, r in rows.iterrows():
        assert math.isfinite(r["rmse"]) or r["diverged_steps"] > 0, r["filter"]


def test_diverged_trials_reach_the_table_and_figures_without_warnings(tmp_path):
    """Infinite and NaN errors over several trials: the summaries, the bootstrap and the box plot
    take them without a RuntimeWarning on the console (inf - inf in a spread or a range)."""
    import warnings

    from pfbench.api import run_experiment
    cfg = {"seed": 1, "trials": 3,
           "scenario": {"name": "linear_gaussian", "a": 1.45, "steps": 1100},
           "filters": {"pf": {"particles": 20}, "ukf": {}, "kf": {}}}
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        res = run_experiment(cfg, out=tmp_path / "o")
    rmse = res.trials.set_index("filter")["rmse"]
    assert not np.isfinite(rmse["pf@20"]).all() and np.isfinite(rmse["kf"]).all()
