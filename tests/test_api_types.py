"""Every public API function refuses an argument of the wrong type with a one-line UserError
naming the function and the argument, before anything is written."""
import pytest

import pfbench
from pfbench.errors import UserError

from .conftest import TINY, tree


class _NotAnExecutor:
    def __repr__(self) -> str:          # the same test id in every process (pytest-xdist)
        return "<not an executor>"


BAD = [
    ("workers", "2"), ("workers", 0), ("workers", True), ("workers", 1.5), ("workers", None),
    ("trials", True), ("trials", 1.5), ("trials", -1), ("trials", 0), ("trials", "5"),
    ("seed", "x"), ("seed", -1), ("seed", 1.0), ("seed", False), ("seed", [1]),
    ("overrides", None), ("overrides", "filters.pf.particles=5"), ("overrides", 5),
    ("overrides", [5]), ("overrides", {"a": 1}), ("overrides", [None]),
    ("out", 123), ("out", ["x"]), ("out", b"x"),
    ("resume", "yes"), ("resume", 1), ("force", "no"), ("force", None),
    ("figures", "no"), ("figures", 0),
    ("executor", _NotAnExecutor()), ("executor", "local"), ("executor", 3),
    ("progress", 3), ("progress", "bar"), ("progress", lambda: None),
    ("progress", lambda done: None), ("warn", 1), ("warn", lambda: None),
    ("warn", lambda a, b: None),
    ("figure_format", "gif"), ("figure_format", 3), ("figure_format", None),
]


IDS = [f"{n}={v!r}" if not callable(v) else f"{n}=<function>" for n, v in BAD]


@pytest.mark.parametrize("name,value", BAD, ids=IDS)
@pytest.mark.parametrize("fn", ["run_experiment", "run_until_decided"])
def test_a_wrong_argument_is_one_line_before_anything_is_written(tmp_path, write_config,
                                                                  monkeypatch, fn, name, value):
    cfg = write_config(TINY)
    monkeypatch.chdir(tmp_path)
    kwargs = {"out": tmp_path / "out", name: value}
    if fn == "run_until_decided" and name == "out" and value is None:
        pytest.skip("None is refused by the other test")
    before = tree(tmp_path)
    with pytest.raises(UserError) as err:
        getattr(pfbench, fn)(cfg, **kwargs)
    line = str(err.value)
    assert "\n" not in line and line.startswith(f"{fn}: {name}: expected")
    assert tree(tmp_path) == before and not (tmp_path / "out").exists()


@pytest.mark.parametrize("name,value", [("on_look", 3), ("on_look", lambda: None),
                                        ("max_trials", 0), ("max_trials", "9"),
                                        ("max_trials", 2.5), ("out", None), ("out", 1)])
def test_run_until_decided_checks_its_own_arguments(tmp_path, write_config, monkeypatch, name,
                                                    value):
    cfg = write_config(TINY)
    monkeypatch.chdir(tmp_path)
    kwargs = {"out": tmp_path / "out", name: value}
    with pytest.raises(UserError) as err:
        pfbench.run_until_decided(cfg, **kwargs)
    assert str(err.value).startswith(f"run_until_decided: {name}: expected")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("config", [None, 5, 1.5, ["a.yaml"], object(), b"exp.yaml"])
@pytest.mark.parametrize("fn", ["run_experiment", "run_until_decided"])
def test_a_config_of_the_wrong_type(tmp_path, monkeypatch, fn, config):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UserError) as err:
        getattr(pfbench, fn)(config, out=tmp_path / "out")
    assert str(err.value).startswith(f"{fn}: config: expected") and "\n" not in str(err.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("folder", [None, 123, 1.5, ["x"], b"x", object()])
@pytest.mark.parametrize("fn", ["load_results", "load_trials"])
def test_a_loader_refuses_a_folder_of_the_wrong_type(fn, folder):
    with pytest.raises(UserError) as err:
        getattr(pfbench, fn)(folder)
    assert str(err.value).startswith(f"{fn}: folder: expected") and "\n" not in str(err.value)


def test_an_iterator_of_overrides_is_read_once(tmp_path, write_config, monkeypatch):
    cfg = write_config(TINY)
    monkeypatch.chdir(tmp_path)
    res = pfbench.run_experiment(cfg, overrides=iter(["filters.pf.particles=30"]))
    assert set(res.trials["filter"]) == {"pf@30", "ukf"}


def test_every_public_name_is_covered():
    """The API's functions are the ones this file checks (a new one needs its own row)."""
    functions = {n for n in pfbench.__all__ if callable(getattr(pfbench, n))
                 and n not in ("Result",)}
    assert functions == {"load_results", "load_trials", "run_experiment", "run_until_decided"}


def test_numpy_integers_are_integers(tmp_path, write_config, monkeypatch):
    np = pytest.importorskip("numpy")
    cfg = write_config(TINY)
    monkeypatch.chdir(tmp_path)
    res = pfbench.run_experiment(cfg, trials=np.int64(2), seed=np.int32(3), workers=np.int64(1))
    assert res.meta["trials"] == 2 and res.meta["seed"] == 3


def test_an_executor_class_is_not_an_executor(tmp_path, write_config, monkeypatch):
    from pfbench.runner import LocalExecutor
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UserError, match="run_experiment: executor: expected"):
        pfbench.run_experiment(write_config(TINY), executor=LocalExecutor)
