"""The null estimator: it models nothing and carries the last measurement (the linuxptp ``nullf`` lesson).

Every family compares against it: a filter that cannot beat "the last value held" adds nothing. For a
measurement ``z(k)`` (m,), the prior is the last valid measurement (NaN before the first), the posterior
is ``z(k)`` when valid and the prior otherwise, and the innovation is ``y(k) = z(k) - prior``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from chronofuse.estimation.interface import FrozenResult
from chronofuse.validation import check_array


@dataclass(frozen=True)
class HoldStep(FrozenResult):
    """One epoch: ``x_prior`` (m,), ``x`` (m,), innovation ``y`` (m,), ``skipped``."""

    x_prior: np.ndarray
    x: np.ndarray
    y: np.ndarray
    skipped: bool


@dataclass(frozen=True)
class HoldResult(FrozenResult):
    """``x_prior``, ``x``, ``y`` (trials, steps, m) and ``skipped`` (trials, steps); read-only."""

    x_prior: np.ndarray
    x: np.ndarray
    y: np.ndarray
    skipped: np.ndarray


def hold_last(x_prior: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pure core: ``(x, y, skipped)`` for priors ``x_prior`` (N, m) and measurements ``z`` (N, m)."""
    skipped = np.isnan(z).any(axis=-1)
    x = np.where(skipped[:, None], x_prior, z)
    y = np.where(skipped[:, None], np.nan, z - x_prior)
    return x, y, skipped


class HoldLastEstimator:
    """Null estimator for ``m``-dimensional measurements: the last valid measurement, held (module docstring)."""

    inputs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, m: int = 1):
        self.m = m

    def fit(self, train=None) -> HoldLastEstimator:
        """Nothing to learn; checks ``m`` and resets. Returns self."""
        if not isinstance(self.m, (int, np.integer)) or self.m < 1:
            raise ValueError(f"m == {self.m!r}, must be an integer >= 1")
        self.m_ = int(self.m)
        self.reset()
        return self

    def reset(self) -> None:
        """Forget the held value."""
        self._held = np.full((1, int(self.m)), np.nan)

    def step(self, z) -> HoldStep:
        """Take ``z`` (m,) (NaN or None = missing)."""
        z = np.full(self.m_, np.nan) if z is None else check_array(z, "z", ndim=1, allow_nan=True)
        if z.shape != (self.m_,):
            raise ValueError(f"z has shape {z.shape}, must be ({self.m_},)")
        prior = self._held
        x, y, skipped = hold_last(prior, z[None, :])
        self._held = x
        return HoldStep(x_prior=prior[0], x=x[0], y=y[0], skipped=bool(skipped[0]))

    def run(self, Z) -> HoldResult:
        """Every trial of ``Z`` (trials, steps, m), NaN = missing; the estimator is not changed."""
        Z = check_array(Z, "Z", ndim=3, allow_nan=True)
        if Z.shape[2] != self.m_:
            raise ValueError(f"Z has shape {Z.shape}, its last axis must be m = {self.m_}")
        trials, steps, m = Z.shape
        x_prior, x_post, y = (np.empty(Z.shape) for _ in range(3))
        skipped = np.empty((trials, steps), dtype=bool)
        held = np.full((trials, m), np.nan)
        for k in range(steps):
            x_prior[:, k] = held
            held, y[:, k], skipped[:, k] = hold_last(held, Z[:, k])
            x_post[:, k] = held
        return HoldResult(x_prior=x_prior, x=x_post, y=y, skipped=skipped)
