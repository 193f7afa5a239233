"""Time rng.fill_normal beside the same ziggurat reading its layer and sign from the low bits (the
reading before issue 13), side by side in one process: the move to the high bits must cost
nothing. Prints ns per draw for each, alternating, best of several runs."""
import time

import numpy as np
from numba import njit, types, uint64

from pfbench.rng import _MANT52, _ZKI, _ZWI, STATE, _normal_slow, fill_normal, load_local, \
    next_local, normal, state_from_seed, store_local


@njit(types.Tuple((types.uint64, types.uint64, types.float64))(types.uint64), inline="always")
def _layer_low(r):
    idx = r & uint64(0xFF)
    r >>= uint64(8)
    rabs = (r >> uint64(1)) & _MANT52
    x = rabs * _ZWI[idx]
    return idx, rabs, -x if r & uint64(1) else x


@njit(types.Tuple((types.uint64, types.uint64, types.float64))(types.uint64), inline="always")
def _layer_high(r):
    idx = r >> uint64(56)
    rabs = (r >> uint64(3)) & _MANT52
    x = rabs * _ZWI[idx]
    return idx, rabs, -x if (r >> uint64(55)) & uint64(1) else x


def _make_fill(layer):
    @njit(types.void(STATE, types.float64[::1]))
    def fill(s, z):
        q = load_local(s)
        for i in range(z.size):
            r, q = next_local(q)
            idx, rabs, x = layer(r)
            if rabs < _ZKI[idx]:
                z[i] = x
                continue
            store_local(s, q)
            x = _normal_slow(s, idx, rabs, x)
            z[i] = x if x == x else normal(s)
            q = load_local(s)
        store_local(s, q)
    return fill


fill_high_here = _make_fill(_layer_high)
fill_low_here = _make_fill(_layer_low)


def main(n=2_000_000, rounds=7):
    z = np.empty(n)
    s = state_from_seed(np.random.SeedSequence(0))
    fns = {"high bits (now)": fill_normal, "low bits (before)": fill_low_here,
           "high bits, compiled here": fill_high_here}
    for fn in fns.values():
        fn(s, z[:10])
    best = dict.fromkeys(fns, np.inf)
    for _ in range(rounds):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn(s, z)
            best[name] = min(best[name], (time.perf_counter() - t0) / n * 1e9)
    for name, ns in best.items():
        print(f"{name:<18} {ns:.2f} ns per normal draw")
    print(f"ratio now / before: {best['high bits (now)'] / best['low bits (before)']:.3f}; "
          "compiled alike here: "
          f"{best['high bits, compiled here'] / best['low bits (before)']:.3f}")


if __name__ == "__main__":
    main()
