"""pfbench bench --peers: the bench's UNGM filter written with particles and with filterpy's
resampling (the 'peers' extra), beside pfbench's kernel."""
import pytest
from typer.testing import CliRunner

from pfbench.cli import app

from .conftest import one_line_exit_2

runner = CliRunner()


def test_peers_without_the_extra_is_one_line(monkeypatch):
    """--peers without the 'peers' extra says how to install it, before timing anything."""
    import sys
    monkeypatch.setitem(sys.modules, "particles", None)      # import particles -> ImportError
    res = runner.invoke(app, ["bench", "--peers", "--only", "costs"])
    assert "pip install '.[peers]'" in one_line_exit_2(res)


def test_peers_compute_the_same_filter():
    """Where the extra is installed: the particles and filterpy versions of the bench's filter
    give the same mean RMSE as pfbench's kernel over the same 60 trials, within 4 standard
    errors of the paired difference (fixed seeds)."""
    pytest.importorskip("particles")
    pytest.importorskip("filterpy")
    import numpy as np

    from pfbench.benchmarks import peers
    from pfbench.benchmarks.common import bench_data, bench_model, pfbench_single
    from pfbench.rng import state_from_seed
    mods = peers.peer_modules()
    X, Y = bench_data(60, seed=5)
    model = bench_model()
    state = state_from_seed(np.random.SeedSequence(6))
    np.random.seed(6)
    ours = np.array([np.sqrt(np.mean((pfbench_single(model, Y[k], 100, state)[1:]
                                      - X[k, 1:]) ** 2)) for k in range(60)])
    for make in (peers.particles_pf, peers.filterpy_pf):
        run = make(mods)
        theirs = np.array([np.sqrt(np.mean((run(Y[k], 100) - X[k, 1:]) ** 2))
                           for k in range(60)])
        d = theirs - ours
        assert abs(d.mean()) <= 4 * d.std(ddof=1) / np.sqrt(60), make.__name__
