"""Reproducible randomness (SPEC section 1): one SeedSequence per experiment, a child per trial.

A child is derived from its parent's entropy and spawn key, exactly as ``SeedSequence.spawn`` would
give it to a fresh parent, but without advancing the parent: calling a simulation twice with the same
``SeedSequence`` gives the same numbers, and trial ``i`` does not depend on how many trials run or
which process runs it.
"""

from __future__ import annotations

import numpy as np


def root_seed(seed) -> np.random.SeedSequence:
    """The experiment's root: an int (>= 0) or a SeedSequence (used as is, never mutated)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        return np.random.SeedSequence(int(seed))
    raise TypeError(f"seed == {seed!r}, must be a non-negative int or a numpy.random.SeedSequence")


def child_seed(base: np.random.SeedSequence, *key: int) -> np.random.SeedSequence:
    """The SeedSequence ``base.spawn`` would give at ``key`` (nested keys for grandchildren), without
    mutating ``base``."""
    return np.random.SeedSequence(base.entropy, spawn_key=tuple(base.spawn_key) + key, pool_size=base.pool_size)


def child_rng(base: np.random.SeedSequence, *key: int) -> np.random.Generator:
    """A Generator on :func:`child_seed` ``(base, *key)``."""
    return np.random.default_rng(child_seed(base, *key))
