"""Seed material for a filter run and for the bootstrap: an unambiguous encoding of (seed, trial,
key) as 32-bit words, fed whole to ``numpy.random.SeedSequence``.

A key enters as the SHA-256 digest of its UTF-8 bytes (eight big-endian 32-bit words), so two keys
share a random stream only if their digests collide; an integer enters as its count of 32-bit
words followed by those words, least significant first, so no two (seed, trial) pairs give the same
words, whatever their size. (A CRC-32 of the key, as before, let 'plumless' and 'buckeroo' share
one stream.)
"""
from __future__ import annotations

import hashlib

import numpy as np


def int_words(n: int) -> list[int]:
    """A non-negative integer as [its count of 32-bit words, the words least significant first]
    (0 is [1, 0])."""
    n = int(n)
    if n < 0:
        raise ValueError(f"{n}: expected an integer >= 0")
    words = []
    while True:
        words.append(n & 0xFFFFFFFF)
        n >>= 32
        if not n:
            return [len(words), *words]


def key_words(key: str) -> list[int]:
    """The SHA-256 digest of ``key``'s UTF-8 bytes as eight big-endian 32-bit words."""
    digest = hashlib.sha256(key.encode("utf-8", "surrogatepass")).digest()
    return [int.from_bytes(digest[i:i + 4], "big") for i in range(0, 32, 4)]


def run_entropy(seed: int, trial: int, key: str) -> list[int]:
    """The words of filter run ``key`` of trial ``trial``: int_words(seed) + int_words(trial) +
    key_words(key)."""
    return [*int_words(seed), *int_words(trial), *key_words(key)]


def run_seed(seed: int, trial: int, key: str) -> np.random.SeedSequence:
    """The seed of filter run ``key`` of trial ``trial``: SeedSequence(run_entropy(...))."""
    return np.random.SeedSequence(run_entropy(seed, trial, key))


def keyed_seed(seed: int, key: str) -> np.random.SeedSequence:
    """A stream for ``key`` under the experiment's ``seed`` (the bootstrap's):
    SeedSequence(int_words(seed) + key_words(key))."""
    return np.random.SeedSequence([*int_words(seed), *key_words(key)])
