"""pfbench.kernels, the public kernel API: every name docs/reference/kernels.md documents is
importable, its signature on the page is the compiled one, the page and ``__all__`` agree, and a
plug-in's own @njit kernel can call each kernel and read each constant and type."""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from .conftest import ROOT

PAGE = ROOT / "docs" / "reference" / "kernels.md"


def _rows() -> dict[str, str]:
    """name -> its signature cell, of every table row of the page."""
    rows = {}
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\| `([A-Za-z_][A-Za-z0-9_]*)` \| (.*?) \|", line)
        if m:
            assert m.group(1) not in rows, f"{m.group(1)} documented twice"
            rows[m.group(1)] = m.group(2)
    return rows


def test_the_page_and_all_agree():
    import pfbench.kernels as k
    rows = _rows()
    assert sorted(rows) == sorted(k.__all__)
    assert len(set(k.__all__)) == len(k.__all__)
    for name in k.__all__:
        assert hasattr(k, name), name
    # the groups partition __all__
    assert sorted(k.KERNELS + k.CONSTANTS + k.TYPES + k.PYTHON) == sorted(k.__all__)


def test_every_documented_name_imports():
    ns: dict = {}
    exec(f"from pfbench.kernels import {', '.join(_rows())}", ns)
    assert all(name in ns for name in _rows())


def test_the_page_states_the_compiled_signatures():
    import pfbench.kernels as k
    rows = _rows()
    for name in k.KERNELS:
        assert rows[name] == f"`{k.signature_text(name)}`", name
    for name in k.CONSTANTS:
        assert rows[name] == f"`int` constant ({getattr(k, name)})", name
    for name in k.PYTHON:
        assert rows[name].startswith("Python: "), name
    assert rows["STATE"] == "`uint64[::1]`" and k._type_text(k.STATE) == "uint64[::1]"
    sig = k.MODEL_SIG
    assert rows["MODEL_SIG"] == ("`(x: {}, t: {}, theta: {}, out: {}) -> {}`".format(
        *(k._type_text(a) for a in (*sig.args, sig.return_type))))


def test_reexported_not_copied():
    """Each name is its owner's object: the kernels pfbench's filters call."""
    import pfbench.kernels as k
    from pfbench import angles, codes, resampling, rng
    from pfbench.filters import weights
    from pfbench.models import scalar
    owners = {rng: ("next_u64", "unit", "uniform", "normal", "fill_normal", "add_normal",
                    "fill_uniform", "standard_gamma", "state_from_seed", "STATE"),
              scalar: ("add_process_noise", "process_logpdf", "MODEL_SIG", "ModelFn",
                       "ModelFunction", "model_function"),
              resampling: ("resample", "multinomial", "systematic", "stratified", "residual",
                           "SCHEMES", "ancestors", "ess_threshold"),
              codes: ("SCHEME_CODES", "SCHEME_MULTINOMIAL", "SCHEME_SYSTEMATIC",
                      "SCHEME_STRATIFIED", "SCHEME_RESIDUAL", "NOISE_GAUSSIAN", "NOISE_GAMMA"),
              weights: ("normalise", "normalised", "divide", "ess", "log_sum_exp"),
              angles: ("wrap",)}
    assert sorted(n for names in owners.values() for n in names) == sorted(k.__all__)
    for module, names in owners.items():
        for name in names:
            assert getattr(k, name) is getattr(module, name), name


def test_a_plugin_kernel_calls_every_kernel():
    """A plug-in's own kernel, compiled by numba (no explicit signature, as a newcomer writes
    it), calls every kernel of the API and reads every constant; a second one takes model
    functions as ModelFn. The results are what each documents."""
    from numba import njit, types

    import pfbench.kernels as k
    from pfbench.kernels import (NOISE_GAMMA, NOISE_GAUSSIAN, SCHEME_MULTINOMIAL,
                                 SCHEME_RESIDUAL, SCHEME_STRATIFIED, SCHEME_SYSTEMATIC, STATE,
                                 MODEL_SIG, ModelFn, add_normal, add_process_noise, divide, ess,
                                 fill_normal, fill_uniform, log_sum_exp, multinomial, next_u64,
                                 normal, normalise, normalised, process_logpdf, resample, residual,
                                 standard_gamma, stratified, systematic, uniform, unit, wrap)

    @njit
    def mine(s, noise, lw, out, idx):
        out[0] = unit(next_u64(s))
        out[1] = uniform(s)
        out[2] = normal(s)
        z = np.empty(3)
        fill_normal(s, z)
        add_normal(s, 2.0, z)
        fill_uniform(s, z)
        out[3] = z.min()
        out[4] = standard_gamma(s, 2.0)
        x = np.zeros(lw.size)
        add_process_noise(s, noise, x)
        out[5] = x.min()
        out[6] = process_logpdf(noise, 0.5)
        w = np.empty(lw.size)
        mx = -np.inf
        for i in range(lw.size):
            mx = max(mx, lw[i])
        total = log_sum_exp(lw)                 # before normalise shifts lw
        S, S2, _, under = normalise(lw, w, x, mx)
        out[7] = ess(S, S2)
        out[8] = total
        out[9] = under
        W = np.empty(lw.size)
        lw2 = np.log(w)
        out[10] = normalised(lw2, W, 0.0)
        divide(w, S, w)
        out[11] = wrap(3.0 * math.pi)
        n = lw.size
        schemes = np.array([SCHEME_MULTINOMIAL, SCHEME_SYSTEMATIC, SCHEME_STRATIFIED,
                            SCHEME_RESIDUAL])
        for j in range(schemes.size):
            resample(schemes[j], w, 1.0, s, idx[j * n:(j + 1) * n])
        multinomial(w, 1.0, s, idx[4 * n:5 * n])
        systematic(w, 1.0, s, idx[5 * n:6 * n])
        stratified(w, 1.0, s, idx[6 * n:7 * n])
        residual(w, 1.0, s, idx[7 * n:8 * n])
        out[12] = NOISE_GAUSSIAN + 10 * NOISE_GAMMA
        return S

    s = k.state_from_seed(np.random.SeedSequence(7))
    start = s.copy()
    lw = np.array([-1000.0, -1001.0, -np.inf, -1000.5])
    expected_lse = -1000.0 + math.log(1.0 + math.exp(-1.0) + math.exp(-0.5))
    out, idx = np.zeros(13), np.full(32, -1, dtype=np.int64)
    noise = np.array([float(NOISE_GAUSSIAN), 0.25, 0.0, 1.0])
    S = mine(s, noise, lw.copy(), out, idx)
    assert not np.array_equal(s, start)             # the state advanced in place
    assert 0.0 <= out[0] < 1.0 and 0.0 <= out[1] < 1.0 and 0.0 <= out[3] < 1.0
    assert out[4] > 0.0 and math.isfinite(out[2]) and math.isfinite(out[5])
    assert out[6] == pytest.approx(-0.5 * 0.25 / 0.25 - 0.5 * math.log(2 * math.pi * 0.25))
    w = np.exp(np.array([0.0, -1.0, -np.inf, -0.5]))
    assert S == pytest.approx(w.sum())
    assert out[7] == pytest.approx(w.sum() ** 2 / (w * w).sum())
    assert out[8] == pytest.approx(expected_lse, abs=1e-12)
    assert out[9] == 0.0 and out[10] == 0.0
    assert out[11] == pytest.approx(-math.pi)
    assert out[12] == 10.0
    assert ((idx >= 0) & (idx < 4) & (idx != 2)).all()     # never the zero-weight particle
    # the same seed, the same numbers
    out2, idx2 = np.zeros(13), np.full(32, -1, dtype=np.int64)
    mine(start, noise, lw.copy(), out2, idx2)
    assert np.array_equal(out, out2) and np.array_equal(idx, idx2)

    @njit(types.float64(ModelFn, types.float64[::1], STATE), cache=False)
    def through_model(f, theta, s):
        x = np.empty(2)
        fill_normal(s, x)
        out = np.empty(2)
        f(x, 1.0, theta, out)
        return out[0] - theta[0] * x[0]

    @njit(MODEL_SIG)
    def scale(x, t, theta, out):
        for i in range(x.size):
            out[i] = theta[0] * x[i]

    theta = np.array([3.0])
    assert through_model(k.model_function(scale), theta, s.copy()) == 0.0
    assert through_model(scale, theta, s.copy()) == 0.0     # a plain dispatcher works too


def test_log_sum_exp_edges():
    from pfbench.kernels import log_sum_exp
    assert log_sum_exp(np.empty(0)) == -np.inf
    assert log_sum_exp(np.full(3, -np.inf)) == -np.inf
    assert log_sum_exp(np.array([np.nan, np.nan])) == -np.inf
    assert log_sum_exp(np.array([0.0, np.inf])) == np.inf
    assert log_sum_exp(np.array([np.nan, 0.0, 0.0])) == pytest.approx(math.log(2.0))
    assert log_sum_exp(np.array([800.0, 800.0])) == pytest.approx(800.0 + math.log(2.0))
    assert log_sum_exp(np.array([-800.0])) == -800.0


def test_ess_is_the_one_formula():
    from pfbench.kernels import ess
    assert ess(2.0, 2.0) == 2.0
    assert ess(1.0, 0.25) == 4.0


def test_python_entries():
    from pfbench.kernels import (SCHEME_CODES, SCHEMES, ancestors, ess_threshold,
                                 state_from_seed)
    s = state_from_seed(np.random.SeedSequence(3))
    assert s.dtype == np.uint64 and s.shape == (4,)
    assert set(SCHEME_CODES) == set(SCHEMES)
    idx = ancestors([0.0, 1.0, 0.0], "systematic", s)
    assert list(idx) == [1, 1, 1]
    assert ess_threshold({"resample": "always", "neff_ratio": 0.5}, 10) == np.inf
    assert ess_threshold({"resample": "neff", "neff_ratio": 0.5}, 10) == 5.0


@pytest.mark.slow
def test_the_pages_example_runs(tmp_path):
    """The page's complete example, run as a file of its own: a plug-in kernel of the API's
    names on one trial of UNGM."""
    text = PAGE.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.DOTALL)
    example = next(b for b in blocks if "__main__" in b)
    path = tmp_path / "plugin_pf.py"
    path.write_text(example, encoding="utf-8")
    done = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    rmse = float(done.stdout.split()[-1])
    assert math.isfinite(rmse) and rmse < 20.0
