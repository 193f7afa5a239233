"""A filter run's random stream: a collision-resistant, injective derivation of (seed, trial, key)
(pfbench.seeding), independent of workers and order."""
from __future__ import annotations

import hashlib
import struct
import zlib

import numpy as np
import pytest

from pfbench.config import load
from pfbench.runner import data_seed, filter_seed, run_trial
from pfbench.seeding import int_words, key_words, keyed_seed, run_entropy

TWINS = """\
seed: 7
trials: 3
scenario: {name: ungm, steps: 20}
filters:
  plumless: {type: pf, label: A, particles: 30}
  buckeroo: {type: pf, label: B, particles: 30}
"""


def _state(seq: np.random.SeedSequence) -> list[int]:
    return seq.generate_state(4, np.uint64).tolist()


def test_keys_with_one_crc32_get_different_streams_and_numbers(write_config):
    assert zlib.crc32(b"plumless") == zlib.crc32(b"buckeroo")      # the pair collides
    assert _state(filter_seed(7, 0, "plumless")) != _state(filter_seed(7, 0, "buckeroo"))
    exp = load(write_config(TWINS))
    for k in range(exp.trials):
        rmse = {r["filter"]: r["rmse"] for r in run_trial(exp, k)}
        assert rmse["plumless@30"] != rmse["buckeroo@30"], k


def _words(n: int) -> list[int]:
    """The documented integer encoding, written out: the count of 32-bit words, then the words
    least significant first."""
    out = []
    while True:
        out.append(n % 2 ** 32)
        n //= 2 ** 32
        if n == 0:
            return [len(out)] + out


@pytest.mark.parametrize("seed,trial,key", [
    (0, 0, "pf@100"), (7, 3, "plumless"), (2 ** 32, 5, "ukf"), (2 ** 200 + 9, 2 ** 40, "é@ß"),
    (20261201, 1, ""), (1, 2, "a" * 300)])
def test_the_documented_formula(seed, trial, key):
    digest = hashlib.sha256(key.encode("utf-8")).digest()
    words = _words(seed) + _words(trial) + list(struct.unpack(">8I", digest))
    assert run_entropy(seed, trial, key) == words
    assert _state(filter_seed(seed, trial, key)) == _state(np.random.SeedSequence(words))
    # the data keep their stream: child (k, 0) of SeedSequence(seed)
    assert _state(data_seed(seed, trial)) == _state(np.random.SeedSequence(seed,
                                                                           spawn_key=(trial, 0)))
    assert keyed_seed(seed, key).entropy == _words(seed) + list(struct.unpack(">8I", digest))


def test_the_encoding_is_injective_where_plain_words_would_not_be():
    # (seed, trial) pairs whose plain 32-bit words run into each other
    pairs = [(2 ** 32, 0), (0, 2 ** 32), (1, 0), (0, 1), (2 ** 32 + 1, 1), (1, 2 ** 32 + 1),
             (2 ** 64, 0), (0, 0)]
    seen = {tuple(run_entropy(s, t, "k")): (s, t) for s, t in pairs}
    assert len(seen) == len(pairs)
    assert len({_state(filter_seed(s, t, "k"))[0] for s, t in pairs}) == len(pairs)
    assert int_words(0) == [1, 0] and int_words(2 ** 32) == [2, 0, 1]
    assert key_words("a") != key_words("a\x00") and len(key_words("")) == 8
    with pytest.raises(ValueError):
        int_words(-1)


def test_a_runs_stream_depends_on_its_key_not_on_order_or_company(write_config):
    exp = load(write_config(TWINS))
    plum = "  plumless: {type: pf, label: A, particles: 30}\n"
    flipped = load(write_config(TWINS.replace(plum, "") + plum
                                + "  other: {type: pf, label: C, particles: 30}\n", "flipped.yaml"))
    assert [r.key for r in flipped.filters] == ["buckeroo@30", "plumless@30", "other@30"]
    for k in (2, 0):     # trials in another order
        a = {r["filter"]: r["rmse"] for r in run_trial(exp, k)}
        b = {r["filter"]: r["rmse"] for r in run_trial(flipped, k)}
        assert a["plumless@30"] == b["plumless@30"] and a["buckeroo@30"] == b["buckeroo@30"]


def test_a_folder_of_trials_drawn_by_the_older_streams_is_not_taken_for_this_experiment(
        tmp_path, write_config):
    """A results folder from before the streams changed holds the same seed, scenario and filters
    but other numbers: it is refused (and never resumed into), naming why."""
    import hashlib as hl
    import json

    from pfbench.errors import UserError
    from pfbench.runner import run_experiment
    exp = load(write_config(TWINS))
    out = tmp_path / "old"
    run_experiment(exp, out)
    meta = json.loads((out / "meta.json").read_text())
    ident = {k: v for k, v in meta["identity"].items() if k != "streams"}   # as older ones
    meta["identity"] = ident
    meta["experiment_hash"] = hl.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:16]
    (out / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(UserError, match="random streams drawn by another pfbench"):
        run_experiment(exp, out)
    with pytest.raises(UserError, match="different experiment"):
        run_experiment(exp, out, resume=True)
