"""The GPSDO's operating state, reported every second with the reason for each change.

States (the GNSSDO paper section 3.2 (3): once disciplined "the system tells the outside that time-keeping may
start"; with every receiver blocked or jammed it "enters time-keeping mode and says so")::

    FREE_RUN --usable reference--> ACQUIRING --|offset| < lock_threshold for lock_hold_s--> LOCKED
    ACQUIRING --no usable reference--> FREE_RUN
    LOCKED --no usable reference / integrity alarm--> HOLDOVER --usable again--> RECOVERY
    RECOVERY --|offset| < lock_threshold for lock_hold_s--> LOCKED;  RECOVERY --lost again--> HOLDOVER

"usable" is the qualified, fused reference of this second with no integrity alarm. The lock test uses
the measured offset ``|z_k|`` of the second (the servo's input), so locking needs ``lock_hold_s``
consecutive seconds under the threshold. A DAC near a rail is an alarm reported beside the state
(it does not change the state: the loop still works, but its tuning range is about to run out).

Functional core :func:`advance` on (N,) arrays; :class:`StateMachine` streams one loop; :func:`run_states`
runs (trials, steps) with the same core.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from chronofuse.discipline.kernels import states_kernel
from chronofuse.discipline.servo import freeze
from chronofuse.validation import check_array, check_scalar

__all__ = ["State", "Reason", "StateConfig", "StateRun", "StateMachine", "advance", "run_states"]


class State(IntEnum):
    FREE_RUN = 0
    ACQUIRING = 1
    LOCKED = 2
    HOLDOVER = 3
    RECOVERY = 4


class Reason(IntEnum):
    """Why the state changed this second (NONE: it did not)."""

    NONE = 0
    REFERENCE_USABLE = 1
    REFERENCE_LOST = 2
    LOCK_ACHIEVED = 3
    INTEGRITY_ALARM = 4


@dataclass(frozen=True)
class StateConfig:
    """``lock_threshold_s`` (> 0): |offset| below which the loop counts as settled; ``lock_hold_s``
    (>= 1 sample): how long it must stay there; ``interval_s``: seconds per sample."""

    lock_threshold_s: float = 100e-9
    lock_hold_s: float = 60.0
    interval_s: float = 1.0

    def __post_init__(self):
        check_scalar(self.lock_threshold_s, "lock_threshold_s", min_val=0.0, include_min=False)
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.lock_hold_s, "lock_hold_s", min_val=self.interval_s)

    @property
    def hold_samples(self) -> int:
        return int(round(self.lock_hold_s / self.interval_s))


def advance(state, settled_run, usable, alarm, offset_s, config: StateConfig):
    """One second for N loops: ``(state (N,) int, settled_run (N,) int, usable, alarm (bool), offset_s)``
    -> ``(state', settled_run', reason)``; returns new arrays."""
    s = np.asarray(state)
    ok = usable & ~alarm
    settled = ok & (np.abs(np.where(ok, offset_s, np.inf)) < config.lock_threshold_s)
    run = np.where(settled, settled_run + 1, 0)
    new = s.copy()
    reason = np.zeros(s.shape, dtype=np.int8)
    lost_reason = np.where(alarm, Reason.INTEGRITY_ALARM, Reason.REFERENCE_LOST)

    def move(mask, to, why):
        new[mask] = to
        reason[mask] = np.broadcast_to(why, mask.shape)[mask]

    move((s == State.FREE_RUN) & ok, State.ACQUIRING, Reason.REFERENCE_USABLE)
    move((s == State.ACQUIRING) & ~ok, State.FREE_RUN, lost_reason)
    move((s == State.LOCKED) & ~ok, State.HOLDOVER, lost_reason)
    move((s == State.HOLDOVER) & ok, State.RECOVERY, Reason.REFERENCE_USABLE)
    move((s == State.RECOVERY) & ~ok, State.HOLDOVER, lost_reason)
    locking = ((s == State.ACQUIRING) | (s == State.RECOVERY)) & (run >= config.hold_samples)
    move(locking, State.LOCKED, Reason.LOCK_ACHIEVED)
    return new, run, reason


@dataclass(frozen=True)
class StateRun:
    """States and reasons per second, (trials, steps) int8, and the DAC-rail alarm (bool), read-only."""

    state: np.ndarray
    reason: np.ndarray
    rail_alarm: np.ndarray

    def __post_init__(self):
        freeze(self)

    def seconds_in(self, interval_s: float = 1.0) -> dict[str, float]:
        """Seconds spent in each state, summed over trials and divided by the number of trials."""
        trials = self.state.shape[0]
        return {s.name.lower(): float(np.sum(self.state == s) * interval_s / trials) for s in State}

    def changes(self, trial: int = 0) -> list[dict]:
        """The transitions of one trial: ``{"step", "to", "reason"}`` in order."""
        steps = np.flatnonzero(self.reason[trial])
        return [{"step": int(k), "to": State(self.state[trial, k]).name.lower(),
                 "reason": Reason(self.reason[trial, k]).name.lower()} for k in steps]


def run_states(usable, offset_s, config: StateConfig = StateConfig(), *, alarm=None, near_rail=None,
               fast: bool = True) -> StateRun:
    """States of (trials, steps) loops from their usable mask, measured offsets and alarms.

    ``fast``: the compiled :func:`~.kernels.states_kernel`; otherwise :func:`advance` second by second
    (its readable twin; tested equal)."""
    usable = np.asarray(usable, dtype=bool)
    if usable.ndim != 2:
        raise ValueError(f"usable has shape {usable.shape}, must have 2 dimension(s)")
    offset = check_array(offset_s, "offset_s", ndim=2, allow_nan=True)
    alarm = np.zeros(usable.shape, bool) if alarm is None else np.asarray(alarm, dtype=bool)
    near = np.zeros(usable.shape, bool) if near_rail is None else np.asarray(near_rail, dtype=bool)
    trials, steps = usable.shape
    if fast:
        states, reasons = states_kernel(usable, alarm, np.where(np.isnan(offset), np.inf, offset),
                                        float(config.lock_threshold_s), config.hold_samples)
        return StateRun(states, reasons, near.copy())
    state = np.full(trials, State.FREE_RUN, dtype=np.int8)
    run = np.zeros(trials, dtype=np.int64)
    states = np.empty((trials, steps), dtype=np.int8)
    reasons = np.empty((trials, steps), dtype=np.int8)
    for k in range(steps):
        state, run, reasons[:, k] = advance(state, run, usable[:, k], alarm[:, k], offset[:, k], config)
        states[:, k] = state
    return StateRun(states, reasons, near.copy())


class StateMachine:
    """Streaming state of one GPSDO; :meth:`step` returns ``(State, Reason)`` for the second."""

    def __init__(self, config: StateConfig = StateConfig()):
        self.config = config
        self.reset()

    def reset(self) -> None:
        self._state = np.array([State.FREE_RUN], dtype=np.int8)
        self._run = np.zeros(1, dtype=np.int64)

    def step(self, usable: bool, offset_s: float, alarm: bool = False) -> tuple[State, Reason]:
        self._state, self._run, reason = advance(self._state, self._run, np.array([bool(usable)]),
                                                 np.array([bool(alarm)]), np.array([float(offset_s)]), self.config)
        return State(int(self._state[0])), Reason(int(reason[0]))
