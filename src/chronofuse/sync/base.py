"""The one interface of every two-way sync algorithm, and its inputs and result.

An algorithm is a scikit-learn-style object: ``__init__`` stores its arguments, ``fit`` validates them
(and learns, for the learnt ones) and returns ``self``. Its pure functional core is
``init_state(trials)`` and ``update(state, sample) -> (new_state, estimate)`` on arrays with a leading
trial axis; ``update`` never writes into ``state``. The streaming ``reset``/``step`` and the batch
``run`` both call that core, so they give the same numbers (a test proves it), and ``run`` leaves the
object untouched and returns a frozen :class:`SyncResult` with read-only arrays.

Estimates are of the offset ``eps = x_B - x_A`` (B's clock minus A's, s) at each exchange.

This is the :mod:`chronofuse.estimation.interface` contract: ``inputs`` (none), ``fit(train=None)``,
``reset()``, ``step(z)`` on one trial's exchange ``z`` (6,) (the columns of :data:`MEASUREMENT_COLUMNS`)
returning a frozen :class:`SyncStep`, and ``run(Z)`` on ``Z`` (trials, steps, 6) returning a
:class:`SyncResult`; :func:`~chronofuse.estimation.interface.compare_streaming_to_batch` checks them.
Besides the offset, an algorithm may report its own uncertainty (``uncertainty(state)``, s, 1 sigma; NaN
when it has none) and a node state (``node_state(state)``, :mod:`chronofuse.sync.states`; -1 when it has
none).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from typing import ClassVar

from chronofuse.estimation.interface import FrozenResult
from chronofuse.models.link import Exchanges
from chronofuse.validation import check_array, check_scalar

__all__ = ["ExchangeSample", "MEASUREMENT_COLUMNS", "measurement_array", "SyncStep", "SyncResult",
           "SyncAlgorithm", "NullSync"]


@dataclass(frozen=True)
class ExchangeSample:
    """What node A has after exchange ``k``: arrays of shape (trials,), s (velocity m/s, SNR dB).

    ``t_i_s``, ``t_b_s``, ``t_r_s``: the paper's three timestamps relative to the slot start
    (``t1 = 0``); ``velocity_m_s``: the Doppler radial velocity; ``snr_db``: the measured SNR;
    ``a_los_velocity_m_s``: A's own velocity along the line of sight (navigation); ``t_s``: the slot epoch
    ``k interval_s``. A lost exchange is NaN.
    """

    k: int
    t_s: float
    t_i_s: np.ndarray
    t_b_s: np.ndarray
    t_r_s: np.ndarray
    velocity_m_s: np.ndarray
    snr_db: np.ndarray
    a_los_velocity_m_s: np.ndarray
    reference_offset_s: np.ndarray | None = None

    @classmethod
    def from_array(cls, k: int, interval_s: float, z: np.ndarray, reference_offset_s=None) -> "ExchangeSample":
        """Exchange ``k`` from ``z`` of shape (trials, 6) (columns :data:`MEASUREMENT_COLUMNS`);
        ``reference_offset_s`` (trials,), optional: a GNSS time comparison of the two nodes (NaN: none)."""
        return cls(k, k * interval_s, z[:, 0], z[:, 1], z[:, 2], z[:, 3], z[:, 4], z[:, 5], reference_offset_s)


#: The columns of a measurement array ``Z`` (trials, steps, 6) that every sync algorithm takes.
MEASUREMENT_COLUMNS = ("t_i_s", "t_b_s", "t_r_s", "velocity_m_s", "snr_db", "a_los_velocity_m_s")


def measurement_array(ex: Exchanges) -> np.ndarray:
    """The measured part of simulated exchanges as ``Z`` (trials, steps, 6) (truth left behind)."""
    return np.stack([ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s, ex.snr_db, ex.a_los_velocity_m_s], axis=-1)


@dataclass(frozen=True)
class SyncStep:
    """One exchange of one trial: ``offset_s``, the estimate of ``eps`` after it (NaN: none yet), its
    ``uncertainty_s`` (1 sigma; NaN when the algorithm has none) and ``node_state`` (-1: none)."""

    offset_s: float
    uncertainty_s: float = float("nan")
    node_state: int = -1


@dataclass(frozen=True)
class SyncResult(FrozenResult):
    """A batch run: ``offset_s``, ``uncertainty_s`` and ``node_state`` (trials, steps), read-only;
    ``algorithm``, the algorithm's name."""

    offset_s: np.ndarray
    uncertainty_s: np.ndarray | None = None
    node_state: np.ndarray | None = None
    algorithm: str = ""


class SyncAlgorithm(ABC):
    """Base of every sync algorithm: subclasses define ``name``, ``init_state`` and ``update``.

    ``interval_s`` (the exchange interval, s) is a constructor argument of every algorithm.
    """

    name = "base"
    inputs: ClassVar[tuple[str, ...]] = ()
    interval_s: float = 0.01

    def fit(self, train=None) -> "SyncAlgorithm":
        """Validate the parameters (the learnt algorithms also train on ``train``); reset; return ``self``."""
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        self._check_params()
        self._learn(train)
        self.fitted_ = True
        self.reset()
        return self

    def _check_params(self) -> None:
        """Subclasses validate their stored arguments here."""

    def _learn(self, train) -> None:
        """Subclasses that learn from data do it here; the classical algorithms have nothing to learn."""

    @abstractmethod
    def init_state(self, trials: int) -> dict:
        """State before the first exchange, arrays with a leading axis of length ``trials``."""

    @abstractmethod
    def update(self, state: dict, sample: ExchangeSample) -> tuple[dict, np.ndarray]:
        """Pure core: the new state and the offset estimate (trials,) after ``sample``; ``state`` untouched."""

    def uncertainty(self, state: dict) -> np.ndarray | None:
        """The 1-sigma uncertainty (trials,) of the estimate in ``state``, s; None: the algorithm has none."""
        return None

    def node_state(self, state: dict) -> np.ndarray | None:
        """The node state code (trials,) in ``state`` (:mod:`chronofuse.sync.states`); None: none."""
        return None

    def _check_fitted(self) -> None:
        if not getattr(self, "fitted_", False):
            raise RuntimeError(f"this {type(self).__name__} is not fitted yet: call fit() first")

    def reset(self) -> None:
        """Forget the streaming state (one trial)."""
        if getattr(self, "fitted_", False):
            self._state = self.init_state(1)
            self._k = 0

    def step(self, z, reference_offset_s=None) -> SyncStep:
        """Streaming: one exchange ``z`` (6,) of one trial (columns :data:`MEASUREMENT_COLUMNS`), with an
        optional reference offset (a GNSS time comparison; NaN or None: none)."""
        self._check_fitted()
        z = check_array(z, "z", ndim=1, allow_nan=True)
        if z.shape != (len(MEASUREMENT_COLUMNS),):
            raise ValueError(f"z has shape {z.shape}, must be ({len(MEASUREMENT_COLUMNS)},) = {MEASUREMENT_COLUMNS}")
        ref = None if reference_offset_s is None else np.array([float(reference_offset_s)])
        self._state, est = self.update(self._state, ExchangeSample.from_array(self._k, self.interval_s, z[None, :], ref))
        self._k += 1
        unc, code = self.uncertainty(self._state), self.node_state(self._state)
        return SyncStep(offset_s=float(est[0]), uncertainty_s=float("nan") if unc is None else float(unc[0]),
                        node_state=-1 if code is None else int(code[0]))

    def run(self, Z, reference_offset_s=None) -> SyncResult:
        """Batch over ``Z`` (trials, steps, 6) through the same core, with optional reference offsets
        (trials, steps) (NaN: none at that exchange); does not mutate ``self``."""
        Z, ref = self._check_run(Z, reference_offset_s)
        trials, steps, _ = Z.shape
        state = self.init_state(trials)
        out = np.empty((trials, steps))
        unc = np.full((trials, steps), np.nan)
        codes = np.full((trials, steps), -1, dtype=np.int64)
        for k in range(steps):
            sample = ExchangeSample.from_array(k, self.interval_s, Z[:, k], None if ref is None else ref[:, k])
            state, out[:, k] = self.update(state, sample)
            u, c = self.uncertainty(state), self.node_state(state)
            if u is not None:
                unc[:, k] = u
            if c is not None:
                codes[:, k] = c
        return SyncResult(offset_s=out, uncertainty_s=unc, node_state=codes, algorithm=self.name)

    def _check_run(self, Z, reference_offset_s):
        self._check_fitted()
        Z = check_array(Z, "Z", ndim=3, allow_nan=True)
        if Z.shape[2] != len(MEASUREMENT_COLUMNS):
            raise ValueError(f"Z has shape {Z.shape}, its last axis must be {len(MEASUREMENT_COLUMNS)} = "
                             f"{MEASUREMENT_COLUMNS}")
        ref = None
        if reference_offset_s is not None:
            ref = check_array(reference_offset_s, "reference_offset_s", ndim=2, allow_nan=True)
            if ref.shape != Z.shape[:2]:
                raise ValueError(f"reference_offset_s has shape {ref.shape}, must be {Z.shape[:2]}")
        return Z, ref


class NullSync(SyncAlgorithm):
    """The do-nothing baseline (linuxptp's ``nullf``): the clocks are assumed synchronized, estimate 0."""

    name = "null"

    def __init__(self, interval_s: float = 0.01):
        self.interval_s = interval_s

    def init_state(self, trials):
        return {}

    def update(self, state, sample):
        return state, np.zeros_like(sample.t_i_s)
