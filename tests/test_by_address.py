"""Which kernels keep numba's C-callable entry (pfbench._lazy's ``by_address``): a kernel taken
by its address, as a first-class function value (every model function; every public kernel,
which a plug-in may hand over as a value), keeps it and works as such a value; any other kernel
is compiled without it, and a function taken by address that lacks it is refused in one line,
never called through a null address."""
from __future__ import annotations

import importlib
import pkgutil
import sys

import numpy as np
import pytest
from numba import njit, types

import pfbench
from pfbench._lazy import LazyKernel, kernel
from pfbench.models.scalar import MODEL_SIG, ModelFunction, ModelFunctionError


def _kinds(cls=ModelFunction) -> list[type]:
    """ModelFunction and every kind derived from it (log-likelihood, sampler, scan, SLAM)."""
    return [cls] + [k for sub in cls.__subclasses__() for k in _kinds(sub)]


def _own_kernels() -> dict[str, LazyKernel]:
    """module.name -> each kernel pfbench's modules define (every module imported first, then
    the warm-up's own listing of the kernels, _kernels._names)."""
    from ._kernels import _names
    for mod in pkgutil.walk_packages(pfbench.__path__, "pfbench."):
        if not mod.name.endswith("__main__"):
            importlib.import_module(mod.name)
    return {f"{module}.{attr}": getattr(sys.modules[module], attr)
            for module, attr in _names().values()}


def _sigs(kern: LazyKernel) -> list:
    return list(kern._sigs) if isinstance(kern._sigs, (list, tuple)) else [kern._sigs]


def _has_entry(disp) -> bool:
    """Whether the compiled first signature of ``disp`` holds the C-callable wrapper."""
    cres = disp.overloads[disp.signatures[0]]
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_cfunc_wrapper_name) != 0


def test_every_model_function_and_public_kernel_is_declared_by_address():
    """A model function (of a scenario or a model module, with a signature a ModelFunction kind
    takes) and each kernel of pfbench.kernels keep the entry; nothing else in pfbench does."""
    import pfbench.kernels as public
    taken = {str(k.SIG) for k in _kinds()}
    kernels = _own_kernels()
    models = {name for name, k in kernels.items()
              if name.startswith(("pfbench.models.", "pfbench.scenarios."))
              and any(str(sig) in taken for sig in _sigs(k))}
    assert len(models) >= 20, sorted(models)
    want = models | {f"{getattr(public, n).__module__}.{getattr(public, n).__name__}"
                     for n in public.KERNELS}
    assert {name for name, k in kernels.items() if k.taken_by_address} == want
    # most of pfbench's kernels (the filters', the simulators', their passes) leave it out
    assert len(kernels) > 3 * len(want)


def test_a_kernel_not_taken_by_address_compiles_without_the_entry():
    """The weights' shifted exponential has a model function's signature but is never taken by
    address: it is compiled without the entry, and still runs from Python."""
    from pfbench.filters.weights import shifted_exp_less
    from pfbench.scenarios.ungm import transition
    assert not shifted_exp_less.taken_by_address
    assert not _has_entry(shifted_exp_less.dispatcher)
    assert _has_entry(transition.dispatcher)
    assert ModelFunction(transition).address != 0


def test_a_public_kernel_works_as_a_first_class_function_value():
    """A plug-in's kernel typed to take a function (numba's FunctionType) is handed pfbench's
    angle wrap as a value: it calls it through its address."""
    from pfbench.kernels import wrap
    fn = types.FunctionType(types.float64(types.float64))

    @njit(types.float64(fn, types.float64))
    def apply(f, x):
        return f(x)

    assert apply(wrap.dispatcher, 3 * np.pi / 2) == wrap(3 * np.pi / 2)


def test_a_model_function_compiled_without_the_entry_is_refused_in_one_line():
    """A pfbench kernel of MODEL_SIG declared without by_address cannot be a model function: the
    model refuses it naming why, instead of handing the filters a null address."""
    @kernel(MODEL_SIG)
    def half(x, t, theta, out):
        out[0] = 0.5 * x[0]

    with pytest.raises(ModelFunctionError) as err:
        ModelFunction(half)
    text = str(err.value)
    assert "\n" not in text and "by_address=True" in text and "half" in text

    @kernel(MODEL_SIG, by_address=True)
    def third(x, t, theta, out):
        out[0] = x[0] / 3.0

    out = np.zeros(1)
    ModelFunction(third)(np.array([3.0]), 0.0, np.zeros(1), out)
    assert out[0] == 1.0
