"""The kernel API for plug-in authors: the names a filter's or a scenario's own numba kernel may
call, public and stable (docs/reference/kernels.md).

Each name is re-exported from the module that owns it, never copied: pfbench's own kernels call
the very same functions. ``__all__`` lists them; docs/reference/kernels.md documents each with
its numba signature (a test holds the two to each other and to the compiled signatures).

In a kernel (``numba.njit``, with or without an explicit signature; ``cache=True`` recommended):

- random draws (pfbench.rng), every one from the generator state ``s``, a ``uint64[::1]`` of 4
  (``STATE`` is its numba type), advanced in place:
  ``next_u64(s) -> uint64``, ``unit(r: uint64) -> float64`` (U[0, 1) from 64 bits),
  ``uniform(s) -> float64``, ``normal(s) -> float64``, ``fill_normal(s, z: float64[::1])``,
  ``add_normal(s, sd: float64, x: float64[::1])`` (x += sd z), ``fill_uniform(s,
  u: float64[::1])``, ``standard_gamma(s, shape: float64) -> float64`` (rate 1);
- process noise of a scalar model (pfbench.models.scalar): ``add_process_noise(s,
  noise: float64[::1], x: float64[::1])`` (x += w, w drawn from ``model.noise`` = [kind, a, b,
  R]; kind ``NOISE_GAUSSIAN``: N(0, a), ``NOISE_GAMMA``: Gamma(shape a, rate b)) and
  ``process_logpdf(noise, w: float64) -> float64``;
- resampling (pfbench.resampling): ``resample(scheme: int64, w: float64[::1], S: float64, s,
  idx: int64[::1])`` fills idx (N,) with N ancestor indices into w (N,), non-negative weights
  of sum S (unnormalised, any magnitude), under ``scheme``, one of ``SCHEME_MULTINOMIAL``,
  ``SCHEME_SYSTEMATIC``, ``SCHEME_STRATIFIED``, ``SCHEME_RESIDUAL`` (``SCHEME_CODES[name]``);
  or a scheme's own kernel, ``multinomial``, ``systematic``, ``stratified``, ``residual``, of
  the same arguments without the code;
- weights (pfbench.filters.weights): ``normalise(lw: float64[::1], w: float64[::1],
  x: float64[::1], m: float64) -> (S, S2, sx, underflow)``, four float64 (max-shifted weights
  from log-weights, their sums), ``normalised(lw: float64[::1], W: float64[::1], mx: float64)
  -> float64`` (underflow), ``divide(w: float64[::1], S: float64, out: float64[::1])``,
  ``ess(S: float64, S2: float64) -> float64``, ``log_sum_exp(lw: float64[::1]) -> float64``;
- angles (pfbench.angles): ``wrap(a: float64) -> float64``, to [-pi, pi);
- the model functions of a scalar model (``model.transition``, ``model.observe``,
  ``model.transition_jac``, ``model.observe_jac``): a kernel declares them ``ModelFn``, the
  numba type of a function of signature ``MODEL_SIG``, ``(x: float64[::1], t: float64,
  theta: float64[::1], out: float64[::1]) -> none``.

``signature_text(name)`` gives a kernel's compiled signature with its arguments' names (what
docs/reference/kernels.md shows). From Python: ``state_from_seed(seed_sequence)`` makes a
state; ``ancestors(weights, scheme, state)`` resamples with every argument checked;
``SCHEMES`` (name -> description) and ``SCHEME_CODES`` (name -> code);
``ess_threshold(params, N)``; ``ModelFunction`` is what a
``ScalarModel`` holds its model functions as (the compiled entry of a ``MODEL_SIG`` function,
whose numba type is ``ModelFn``), and ``model_function(fn)`` makes one.

``ModelFn`` against ``ModelFunction``: ``ModelFn`` is a numba *type*, for a kernel's signature
(``types.void(ModelFn, ...)``); ``ModelFunction`` is the Python *value* handed to that
argument. A scenario writes plain ``numba.njit(MODEL_SIG)`` functions; ``ScalarModel`` wraps
them as ``ModelFunction`` itself, so a filter passes ``model.transition`` to its kernel as it
is.

The generator state: a filter's ``run`` receives ``state``, a fresh ``uint64`` array of 4 for
this trial and this filter run (from a ``numpy.random.SeedSequence`` of the experiment's seed,
the trial and the filter run's key: pfbench.seeding.run_seed, then ``state_from_seed``). It is
the run's own: the run may, and should, advance it in place, by these draws in its kernels (or
``numpy.random.default_rng(state)`` in Python); nothing reads it afterwards. Every random number
comes from it, so a run is a pure function of its inputs; numba's own ``np.random`` inside a
kernel is not seeded by pfbench and makes a run differ between processes.
"""
from __future__ import annotations

from .angles import wrap
from .codes import (NOISE_GAMMA, NOISE_GAUSSIAN, SCHEME_CODES, SCHEME_MULTINOMIAL,
                    SCHEME_RESIDUAL, SCHEME_STRATIFIED, SCHEME_SYSTEMATIC)
from .filters.weights import divide, ess, log_sum_exp, normalise, normalised
from .models.scalar import (MODEL_SIG, ModelFn, ModelFunction, add_process_noise, model_function,
                            process_logpdf)
from .resampling import (SCHEMES, ancestors, ess_threshold, multinomial, resample, residual,
                         stratified, systematic)
from .rng import (STATE, add_normal, fill_normal, fill_uniform, next_u64, normal,
                  standard_gamma, state_from_seed, uniform, unit)

# The kernels a plug-in's own kernel calls, each with its compiled signature.
KERNELS = ("next_u64", "unit", "uniform", "normal", "fill_normal", "add_normal", "fill_uniform",
           "standard_gamma", "add_process_noise", "process_logpdf", "resample", "multinomial",
           "systematic", "stratified", "residual", "normalise", "normalised", "divide", "ess",
           "log_sum_exp", "wrap")
# The constants a kernel reads (numba takes module-level integers as compile-time constants).
CONSTANTS = ("SCHEME_MULTINOMIAL", "SCHEME_SYSTEMATIC", "SCHEME_STRATIFIED", "SCHEME_RESIDUAL",
             "NOISE_GAUSSIAN", "NOISE_GAMMA")
# The numba types a kernel's signature names.
TYPES = ("STATE", "ModelFn", "MODEL_SIG")
# What Python code calls (not a kernel).
PYTHON = ("state_from_seed", "ancestors", "SCHEMES", "SCHEME_CODES", "ess_threshold",
          "ModelFunction", "model_function")

__all__ = [
    "next_u64", "unit", "uniform", "normal", "fill_normal", "add_normal", "fill_uniform",
    "standard_gamma", "add_process_noise", "process_logpdf", "resample", "multinomial",
    "systematic", "stratified", "residual", "normalise", "normalised", "divide", "ess",
    "log_sum_exp", "wrap",
    "SCHEME_MULTINOMIAL", "SCHEME_SYSTEMATIC", "SCHEME_STRATIFIED", "SCHEME_RESIDUAL",
    "NOISE_GAUSSIAN", "NOISE_GAMMA",
    "STATE", "ModelFn", "MODEL_SIG",
    "state_from_seed", "ancestors", "SCHEMES", "SCHEME_CODES", "ess_threshold", "ModelFunction",
    "model_function",
]
assert __all__ == [*KERNELS, *CONSTANTS, *TYPES, *PYTHON]


def _type_text(t) -> str:
    """A numba type as docs/reference/kernels.md writes it: ``float64[::1]`` for a contiguous
    1-d array, ``(a, b)`` for a tuple, ``ModelFn``, ``none``."""
    from numba import types
    if t == ModelFn:
        return "ModelFn"
    if isinstance(t, types.Array):
        dims = ", ".join([":"] * (t.ndim - 1) + ["::1" if t.layout == "C" else ":"])
        return f"{t.dtype}[{dims}]"
    if isinstance(t, types.BaseTuple):
        return "(" + ", ".join(_type_text(e) for e in t) + ")"
    if t == types.none:
        return "none"
    return str(t)


def signature_text(name: str) -> str:
    """The compiled signature of the kernel ``name`` (one of ``KERNELS``), as the reference page
    writes it, with the arguments' names: ``uniform(s: uint64[::1]) -> float64``."""
    import inspect
    fn = globals()[name]
    sig = fn._sigs
    sig = sig[0] if isinstance(sig, (list, tuple)) else sig
    names = list(inspect.signature(fn._func).parameters)
    args = ", ".join(f"{n}: {_type_text(a)}" for n, a in zip(names, sig.args))
    return f"{name}({args}) -> {_type_text(sig.return_type)}"
