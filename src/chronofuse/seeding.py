"""Reproducible randomness: one SeedSequence per experiment, a child per trial.

The one convention for every ``simulate_*`` that takes a ``seed`` (:func:`root_seed`):

- an ``int`` (>= 0) or a ``numpy.random.SeedSequence`` **reproduces**: the same value gives the same
  draws, call after call (a SeedSequence is read, never mutated or spawned from);
- a ``numpy.random.Generator`` is **consumed**: 128 bits drawn from it seed the run, so two calls with
  one Generator give different draws (as two calls of ``rng.standard_normal`` would), while two
  Generators in the same state give the same draws.

A child is derived from its parent's entropy and spawn key, exactly as ``SeedSequence.spawn`` would
give it to a fresh parent, but without advancing the parent: trial ``i`` does not depend on how many
trials run or which process runs it.
"""

from __future__ import annotations

from typing import Union

import numpy as np

__all__ = ["SeedLike", "root_seed", "child_seed", "child_rng"]

#: What a ``seed`` argument accepts (see the module docstring for what each kind means).
SeedLike = Union[int, np.integer, np.random.SeedSequence, np.random.Generator]

# Words of 32 bits drawn from a Generator to seed a run: 128 bits, SeedSequence's own pool size.
_GENERATOR_WORDS = 4


def root_seed(seed: SeedLike) -> np.random.SeedSequence:
    """The run's root SeedSequence under the convention of the module docstring.

    An int (>= 0) gives ``SeedSequence(seed)``; a SeedSequence is returned as is; a Generator gives
    ``SeedSequence(entropy)`` of :data:`_GENERATOR_WORDS` 32-bit words drawn from it (advancing it).
    Anything else (a bool, a negative int, a float, a legacy ``RandomState``) raises ``TypeError``.
    """
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, np.random.Generator):
        words = seed.integers(0, 2**32, size=_GENERATOR_WORDS, dtype=np.uint64)
        return np.random.SeedSequence([int(w) for w in words])
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        return np.random.SeedSequence(int(seed))
    raise TypeError(
        f"seed == {seed!r}, must be a non-negative int, a numpy.random.SeedSequence or a numpy.random.Generator"
    )


def child_seed(base: np.random.SeedSequence, *key: int) -> np.random.SeedSequence:
    """The SeedSequence ``base.spawn`` would give at ``key`` (nested keys for grandchildren), without
    mutating ``base``."""
    return np.random.SeedSequence(base.entropy, spawn_key=tuple(base.spawn_key) + key, pool_size=base.pool_size)


def child_rng(base: np.random.SeedSequence, *key: int) -> np.random.Generator:
    """A Generator on :func:`child_seed` ``(base, *key)``."""
    return np.random.default_rng(child_seed(base, *key))
