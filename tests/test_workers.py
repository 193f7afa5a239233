"""Worker processes that can be stopped at any moment (pfbench.workers): stopping never waits on
a worker, whatever it is doing, and a worker that dies is an error, never a wait."""
from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from pfbench.workers import WorkerDied, Workers

# what the worker processes do: runs of one worker fork theirs here too (tests/conftest.py)
pytestmark = pytest.mark.worker_processes


def _within(seconds, fn, *args):
    """fn(*args), failing the test if it has not returned after ``seconds`` (the thread is left
    behind: what is tested is that nothing waits for ever)."""
    box = {}

    def go():
        try:
            box["out"] = fn(*args)
        except BaseException as exc:     # noqa: BLE001 - handed to the test
            box["exc"] = exc
    t = threading.Thread(target=go, daemon=True)
    start = time.monotonic()
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"{fn.__name__} still waiting after {seconds} s"
    if "exc" in box:
        raise box["exc"]
    return box.get("out"), time.monotonic() - start


def _square(x):
    return x * x


def _sleep_then_echo(x):
    time.sleep(x)
    return x


def _inverse(x):
    return 1 // x


def _huge(n):
    return b"x" * n


def _exit_with(code):
    os._exit(code)


def _stubborn(*_):
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def test_results_come_back_from_the_worker_they_were_sent_to_in_order():
    with Workers(2, _square) as pool:
        for slot in (0, 1):
            for x in (slot + 2, slot + 5):
                pool.send(slot, x)
        got: dict[int, list] = {0: [], 1: []}
        while sum(map(len, got.values())) < 4:
            for slot, ok, out in pool.results(timeout=10):
                assert ok
                got[slot].append(out)
        pool.close()
    assert got == {0: [4, 25], 1: [9, 36]}
    assert all(p.exitcode == 0 for p in pool.procs)


def test_an_exception_comes_back_as_a_result_and_the_worker_goes_on():
    with Workers(1, _inverse) as pool:
        pool.send(0, 0)
        pool.send(0, 1)
        (first,) = _within(10, pool.results, 10)[0]
        assert first[0] == 0 and not first[1] and isinstance(first[2], ZeroDivisionError)
        (second,) = _within(10, pool.results, 10)[0]
        assert second == (0, True, 1)


@pytest.mark.parametrize("code", [3, 0])
def test_a_worker_that_ends_is_an_error_naming_it_with_its_exit_status(code):
    with Workers(2, _exit_with) as pool:
        pool.send(1, code)
        with pytest.raises(WorkerDied) as info:
            for _ in range(40):
                _within(10, pool.results, 0.25)
        assert info.value.slot == 1 and info.value.exitcode == code


def test_a_worker_killed_while_it_writes_a_result_is_an_error_not_a_wait():
    # a 64 MiB result fills the pipe: the worker blocks in the middle of writing it
    with Workers(1, _huge) as pool:
        pool.send(0, 64 << 20)
        time.sleep(0.5)
        os.kill(pool.pids[0], signal.SIGKILL)
        with pytest.raises(WorkerDied) as info:
            _within(20, pool.results, 10)
        assert info.value.exitcode == -signal.SIGKILL


def test_stop_ends_busy_writing_and_stubborn_workers_at_once():
    # one sleeps in its work, one is blocked writing a result nobody reads, one ignores SIGTERM
    # (it is killed a second later); regression: multiprocessing.Pool.terminate could wait for
    # ever on a result queue whose lock a stopped worker held
    busy = Workers(1, _sleep_then_echo)
    writing = Workers(1, _huge)
    stubborn = Workers(1, _sleep_then_echo, setup=_stubborn)
    busy.send(0, 60)
    writing.send(0, 64 << 20)
    stubborn.send(0, 60)
    time.sleep(0.5)
    for pool in (busy, writing, stubborn):
        _, took = _within(15, pool.stop)
        assert took < 10
        assert all(p.exitcode is not None for p in pool.procs)
    assert stubborn.procs[0].exitcode == -signal.SIGKILL


def test_sending_to_a_worker_that_has_ended_is_an_error_naming_it():
    with Workers(1, _exit_with) as pool:
        pool.procs[0].kill()
        pool.procs[0].join()
        with pytest.raises(WorkerDied):
            for _ in range(100):        # a pipe may take a write or two before it breaks
                pool.send(0, 1 << 16)


def _freeze_count(_item):
    import gc
    return gc.get_freeze_count()


def test_workers_start_with_the_parents_objects_frozen_and_the_parent_thaws():
    """The pool forks with the parent's objects out of the collector's reach (gc.freeze: a
    worker's collections then never write to, and so copy, the pages it shares with its
    parent), and the parent's collector has them back once the workers are started."""
    import gc
    keep = [[i] for i in range(10000)]         # objects the collector tracks
    assert gc.get_freeze_count() == 0
    with Workers(1, _freeze_count) as pool:
        assert gc.get_freeze_count() == 0
        pool.send(0, "how many")
        (_, ok, frozen), = pool.results(timeout=30)
        assert ok and frozen >= len(keep)
    assert keep


def _garbage_cycle():
    """A weak reference to an object in a cycle no one holds: garbage only the collector frees."""
    import weakref

    class Node:
        pass
    node = Node()
    node.me = node
    return weakref.ref(node)


def test_a_process_that_keeps_objects_frozen_keeps_them_so_without_its_garbage():
    """A process that froze its objects itself (the command line) keeps them frozen through a
    pool's start, with the new ones, but not the garbage among those: it is collected first."""
    import gc
    gc.freeze()
    try:
        gone = _garbage_cycle()
        kept = gc.get_freeze_count()
        with Workers(1, _freeze_count):
            assert gone() is None
            assert gc.get_freeze_count() >= kept
    finally:
        gc.unfreeze()


def test_a_pool_started_without_collecting_freezes_what_there_is():
    """``collect=False`` (the command line's first fork, right after its imports): no collection
    before the fork; the garbage is frozen with the rest, and the workers still start."""
    import gc
    from unittest import mock
    gc.freeze()
    try:
        gone = _garbage_cycle()
        with mock.patch("gc.collect") as collect:
            with Workers(1, _freeze_count, collect=False) as pool:
                pool.send(0, "how many")
                (_, ok, frozen), = pool.results(timeout=30)
        assert ok and frozen > 0
        collect.assert_not_called()
        assert gone() is not None       # frozen, not collected
    finally:
        gc.unfreeze()
        gc.collect()


def test_the_command_lines_early_worker_starts_without_a_collection(monkeypatch):
    """runner.prestart forks its worker without collecting first (there is next to nothing to
    collect right after the imports, and a full collection before the fork delays the run)."""
    from unittest import mock

    from pfbench import runner
    made = mock.MagicMock()
    monkeypatch.setattr(runner, "Workers", made)
    monkeypatch.setattr(runner, "_EARLY", [])
    monkeypatch.setattr(runner, "_in_process", lambda: False)
    runner.prestart()
    assert made.call_count == 1 and made.call_args.kwargs.get("collect") is False
