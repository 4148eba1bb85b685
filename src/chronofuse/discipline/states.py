"""The GPSDO's operating state, reported every second with the reason for each change.

States (the GNSSDO paper section 3.2 (3): once disciplined "the system tells the outside that time-keeping may
start"; with every receiver blocked or jammed it "enters time-keeping mode and says so")::

    FREE_RUN --usable reference--> ACQUIRING --criteria met for lock_hold_s--> LOCKED
    ACQUIRING --no usable reference--> FREE_RUN
    LOCKED --no usable reference / integrity alarm / implausible reference--> HOLDOVER --usable again--> RECOVERY
    LOCKED --time-error or frequency excursion, DAC near a rail, unresolved offset--> ALARM --criteria met for
        lock_hold_s--> LOCKED;  ACQUIRING, RECOVERY --an unresolved offset over the threshold--> ALARM
    ALARM --no usable reference ...--> HOLDOVER;  RECOVERY --criteria met for lock_hold_s--> LOCKED
    RECOVERY --lost again--> HOLDOVER

LOCKED is a claim: the disciplined 1PPS is within ``lock_threshold_s`` of the reference. It is made, and
kept, only while every lock criterion holds each second:

* the reference is usable: qualified, fused, no integrity alarm, and found plausible by the oscillator's
  own prediction (``implausible`` says it is not);
* the *filtered* time error, Brown's double exponential average of the measured offset over ``te_filter_s``
  (level ``2 s1 - s2`` of an average ``s1`` and its own average ``s2``: no lag on a drifting offset, where a
  single average lags by rate x ``te_filter_s``; restarted at every re-acquisition; an offset more than
  ``lock_threshold_s`` from the level enters as ``lock_threshold_s`` for one second, a reference outlier,
  and restarts the filter where it is if it stays so a second second, a pull-in or a step), is within
  ``criteria_fraction x lock_threshold_s``, and within ``lock_threshold_s - noise_sigmas x sigma_ref``, where
  ``sigma_ref`` is the fused reference's own standard deviation that second (its ``reference_variance_s2``):
  the measured offset is the time error plus the reference's error, and a reference that errs by tens of ns
  for minutes (one urban-canyon receiver left: 31 ns) leaves less of the threshold to claim;
* the frequency correction ``u_k`` the servo applies stays within ``freq_threshold`` of its own exponential
  average over ``freq_filter_s`` (a loop being dragged, or still pulling in, moves it);
* the DAC is away from its rails (``near_rail`` False): a loop at the end of its tuning range no longer
  follows the reference;
* the reference carries no offset the oscillator could not resolve beyond what the threshold leaves: a
  reference refused as implausible (a coherent step of every receiver) and let back in once the holdover
  prediction's tolerance had grown over its miss may still be off by up to ``unresolved_s`` (the miss plus the
  tolerance, :mod:`.plausibility`), and that is kept off the threshold too: ``|filtered| < lock_threshold_s -
  noise_sigmas x sigma_ref - unresolved_s``. Where only this fails, the reason is UNRESOLVED_OFFSET (LOCKED
  goes to ALARM; ACQUIRING and RECOVERY go to ALARM once it leaves no limit at all). It is not
  resolved later (nothing but another reference could tell a step of the reference from the oscillator's
  wander); :meth:`StateMachine.reset` (a new run) clears it.

A criterion lost in LOCKED moves to ALARM (the loop still steers; the output is not claimed locked) with
the criterion as reason; a reference lost or refused moves to HOLDOVER. ``lock_hold_s`` consecutive seconds
with every criterion met lock again.

Every second also reports holdover readiness and a predicted holdover error (:class:`HoldoverModel`):
``holdover_ready`` after ``ready_s`` seconds LOCKED without a break (enough locked time for the servo's
frequency and drift estimates); ``holdover_sigma_s``, the standard deviation of the time error after
``horizon_s`` seconds of holdover started now, from the oscillator's noise model and the scatter of the
frequency correction (the uncertainty of the frequency the holdover would keep)::

    sigma^2(H) = te_f^2 + H^2 s_u^2 + h0 H / 2 + 2 ln2 h_-1 H^2 + (2 pi^2 / 3) h_-2 H^3 + (D H^2 / 2)^2

(white, flicker and random-walk FM: NIST SP 1065 Table 3's Allan variances times ``H^2``, the random walk's
exact integral; ``s_u^2`` the exponential variance of ``u - mean(u)``; ``D`` the aging bound of the data
sheet, an allowance for a drift the servo has not estimated).

Functional core :func:`advance` on (N,) arrays; :class:`StateMachine` streams one loop; :func:`run_states`
runs (trials, steps) with the same core, or its compiled twin :func:`~.kernels.states_kernel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from chronofuse.discipline.kernels import states_kernel
from chronofuse.discipline.servo import freeze
from chronofuse.validation import check_array, check_scalar

__all__ = ["State", "Reason", "StateConfig", "HoldoverModel", "StateRun", "StateMachine", "advance", "run_states"]


class State(IntEnum):
    FREE_RUN = 0
    ACQUIRING = 1
    LOCKED = 2
    HOLDOVER = 3
    RECOVERY = 4
    ALARM = 5


class Reason(IntEnum):
    """Why the state changed this second (NONE: it did not)."""

    NONE = 0
    REFERENCE_USABLE = 1
    REFERENCE_LOST = 2
    LOCK_ACHIEVED = 3
    INTEGRITY_ALARM = 4
    TIME_ERROR_EXCURSION = 5
    FREQUENCY_EXCURSION = 6
    DAC_RAIL = 7
    IMPLAUSIBLE_REFERENCE = 8
    UNRESOLVED_OFFSET = 9


@dataclass(frozen=True)
class HoldoverModel:
    """The oscillator's noise for the holdover prediction: h-coefficients of white, flicker and random-walk
    FM (``h0`` s, ``hm1`` dimensionless, ``hm2`` 1/s) and the data sheet's aging bound ``drift_per_s`` (1/s)."""

    h0: float
    hm1: float
    hm2: float
    drift_per_s: float = 0.0

    @classmethod
    def of(cls, osc) -> HoldoverModel:
        """From an :class:`~chronofuse.models.oscillator.OscillatorModel` (its h and aging)."""
        return cls(osc.h.h0, osc.h.hm1, osc.h.hm2, abs(osc.drift_per_s))

    def variance_s2(self, horizon_s: float) -> float:
        """The free oscillator's time-error variance after ``horizon_s`` from a perfect start (module docstring)."""
        h = float(horizon_s)
        return (self.h0 * h / 2.0 + 2.0 * math.log(2.0) * self.hm1 * h * h
                + 2.0 * math.pi**2 / 3.0 * self.hm2 * h**3 + (self.drift_per_s * h * h / 2.0) ** 2)


@dataclass(frozen=True)
class StateConfig:
    """Lock criteria (module docstring).

    ``lock_threshold_s`` (> 0): the ``|time error|`` LOCKED claims; ``criteria_fraction`` (0, 1]: the filtered
    time error must stay within this fraction of it; ``lock_hold_s`` (>= 1 sample): seconds with every
    criterion met before LOCKED; ``te_filter_s`` (>= 1 sample): the filtered time error's averaging time;
    ``freq_threshold`` (fractional frequency, > 0; None: no frequency criterion) and ``freq_filter_s``;
    ``noise_sigmas`` (>= 0): the fused reference's standard deviations kept off the threshold;
    ``ready_s``: seconds locked before holdover is ready; ``horizon_s``: the predicted holdover's horizon;
    ``holdover``: the oscillator's :class:`HoldoverModel` (None: no prediction); ``interval_s``.
    """

    lock_threshold_s: float = 100e-9
    lock_hold_s: float = 60.0
    interval_s: float = 1.0
    criteria_fraction: float = 0.5
    te_filter_s: float = 10.0
    noise_sigmas: float = 2.0
    freq_threshold: float | None = None
    freq_filter_s: float = 600.0
    ready_s: float = 3600.0
    horizon_s: float = 3600.0
    holdover: HoldoverModel | None = None

    def __post_init__(self):
        check_scalar(self.lock_threshold_s, "lock_threshold_s", min_val=0.0, include_min=False)
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.lock_hold_s, "lock_hold_s", min_val=self.interval_s)
        check_scalar(self.criteria_fraction, "criteria_fraction", min_val=0.0, max_val=1.0, include_min=False)
        check_scalar(self.te_filter_s, "te_filter_s", min_val=self.interval_s)
        check_scalar(self.noise_sigmas, "noise_sigmas", min_val=0.0)
        if self.freq_threshold is not None:
            check_scalar(self.freq_threshold, "freq_threshold", min_val=0.0, include_min=False)
        check_scalar(self.freq_filter_s, "freq_filter_s", min_val=self.interval_s)
        check_scalar(self.ready_s, "ready_s", min_val=0.0)
        check_scalar(self.horizon_s, "horizon_s", min_val=0.0, include_min=False)

    @property
    def hold_samples(self) -> int:
        return int(round(self.lock_hold_s / self.interval_s))

    def kernel_params(self) -> np.ndarray:
        """(te limit, hold samples, te alpha, freq threshold (inf: none), freq alpha, ready samples,
        model variance at the horizon (NaN: none), horizon, threshold, noise sigmas) as float64 for the
        compiled twin."""
        model = math.nan if self.holdover is None else self.holdover.variance_s2(self.horizon_s)
        return np.array([self.criteria_fraction * self.lock_threshold_s, self.hold_samples,
                         self.interval_s / self.te_filter_s,
                         math.inf if self.freq_threshold is None else self.freq_threshold,
                         self.interval_s / self.freq_filter_s, round(self.ready_s / self.interval_s), model,
                         self.horizon_s, self.lock_threshold_s, self.noise_sigmas])


def initial_memory(n: int) -> dict[str, np.ndarray]:
    """The state machine's memory for ``n`` loops: FREE_RUN, nothing filtered yet."""
    return {"state": np.zeros(n, np.int8), "run": np.zeros(n, np.int64), "te_s1": np.full(n, np.nan),
            "te_s2": np.full(n, np.nan), "te_far": np.zeros(n, bool),
            "u_f": np.full(n, np.nan), "u_var": np.zeros(n), "locked": np.zeros(n, np.int64)}


def advance(memory: dict, usable, offset_s, config: StateConfig, *, alarm=None, implausible=None, near_rail=None,
            freq_adj=None, reference_variance_s2=None, unresolved_s=None) -> tuple[dict, np.ndarray, dict]:
    """One second for N loops -> ``(memory', reason (N,) int8, report)``; ``report``: ``filtered_offset_s``,
    ``holdover_ready``, ``holdover_sigma_s`` (N,). Inputs (N,): ``usable`` (a fused reference this second),
    ``offset_s`` (the measured offset), ``alarm`` (integrity), ``implausible`` (refused by the oscillator's
    prediction), ``near_rail``, ``freq_adj`` (the applied frequency correction), ``reference_variance_s2``
    (the fused reference's variance; NaN, negative or None: unknown, no noise margin), ``unresolved_s`` (the
    bound on an offset the reference was let back in with; None: none); new arrays returned."""
    p = config.kernel_params()
    limit, hold, a_te, f_thr, a_u, ready, model_var, horizon, threshold, k_sigma = p
    s = np.asarray(memory["state"])
    n = s.shape
    usable = np.asarray(usable, dtype=bool)
    alarm = np.zeros(n, bool) if alarm is None else np.asarray(alarm, dtype=bool)
    implausible = np.zeros(n, bool) if implausible is None else np.asarray(implausible, dtype=bool)
    near = np.zeros(n, bool) if near_rail is None else np.asarray(near_rail, dtype=bool)
    u = np.zeros(n) if freq_adj is None else np.asarray(freq_adj, dtype=np.float64)
    z = np.asarray(offset_s, dtype=np.float64)
    ref_var = np.zeros(n) if reference_variance_s2 is None else np.asarray(reference_variance_s2, dtype=np.float64)
    known = np.isfinite(ref_var) & (ref_var >= 0.0)  # a negative variance is no variance: unknown
    noise = k_sigma * np.sqrt(np.where(known, ref_var, 0.0))
    unresolved = np.zeros(n) if unresolved_s is None else np.nan_to_num(np.asarray(unresolved_s, dtype=np.float64))
    bare = np.minimum(limit, threshold - noise)  # without the unresolved offset: only that failing is UNRESOLVED_OFFSET
    limit = np.minimum(bare, threshold - noise - unresolved)
    ok = usable & ~alarm & ~implausible & np.isfinite(z)
    # Filters: restarted on the first usable second after a loss (the time error), or the first at all (u).
    # A measured offset more than the threshold from the level, for one second, enters as the threshold (the
    # output is steered in frequency; an outlier of the reference is not a time error); a second one in a row
    # restarts the filter there (a pull-in, a phase step: the offset really moved).
    level = 2.0 * memory["te_s1"] - memory["te_s2"]
    jump = np.where(ok, z, 0.0) - level
    big = ok & np.isfinite(level) & (np.abs(jump) > threshold)
    restart = ~np.isfinite(level) | (big & memory["te_far"])
    z_in = np.where(big, level + np.clip(np.where(big, jump, 0.0), -threshold, threshold), z)
    s1 = np.where(ok, np.where(restart, z, memory["te_s1"] + a_te * (z_in - memory["te_s1"])), np.nan)
    s2 = np.where(ok, np.where(restart, s1, memory["te_s2"] + a_te * (s1 - memory["te_s2"])), np.nan)
    te_f = 2.0 * s1 - s2  # Brown's level: no lag on a ramp (a single average lags a drift by rate x te_filter_s)
    u_prev = memory["u_f"]
    u_f = np.where(np.isfinite(u_prev), u_prev + a_u * (u - u_prev), u)
    dev = u - np.where(np.isfinite(u_prev), u_prev, u)
    u_var = np.where(np.isfinite(u_prev), (1.0 - a_u) * memory["u_var"] + a_u * dev * dev, 0.0)
    te_ok = np.abs(np.where(ok, te_f, np.inf)) < limit
    f_ok = np.abs(dev) < f_thr
    settled = ok & te_ok & f_ok & ~near
    run = np.where(settled, memory["run"] + 1, 0)
    new = s.copy()
    reason = np.zeros(n, dtype=np.int8)
    lost = np.where(implausible, Reason.IMPLAUSIBLE_REFERENCE,
                    np.where(alarm, Reason.INTEGRITY_ALARM, Reason.REFERENCE_LOST)).astype(np.int8)
    te_why = np.where(np.abs(np.where(ok, te_f, np.inf)) < bare, Reason.UNRESOLVED_OFFSET, Reason.TIME_ERROR_EXCURSION)
    broken = np.where(near, Reason.DAC_RAIL, np.where(~te_ok, te_why, Reason.FREQUENCY_EXCURSION)).astype(np.int8)

    def move(mask, to, why):
        new[mask] = to
        reason[mask] = np.broadcast_to(why, n)[mask]

    move((s == State.FREE_RUN) & ok, State.ACQUIRING, Reason.REFERENCE_USABLE)
    move((s == State.ACQUIRING) & ~ok, State.FREE_RUN, lost)
    move(((s == State.LOCKED) | (s == State.ALARM) | (s == State.RECOVERY)) & ~ok, State.HOLDOVER, lost)
    move((s == State.HOLDOVER) & ok, State.RECOVERY, Reason.REFERENCE_USABLE)
    move((s == State.LOCKED) & ok & ~settled, State.ALARM, broken)
    # An unresolved offset that leaves no limit at all: the loop steers, and the state says it cannot lock.
    blocked = ((s == State.ACQUIRING) | (s == State.RECOVERY)) & ok & (limit <= 0.0) & (unresolved > 0.0)
    move(blocked, State.ALARM, Reason.UNRESOLVED_OFFSET)
    locking = ((s == State.ACQUIRING) | (s == State.RECOVERY) | (s == State.ALARM)) & (run >= hold)
    move(locking, State.LOCKED, Reason.LOCK_ACHIEVED)
    locked = np.where(new == State.LOCKED, memory["locked"] + 1, 0)
    sigma = np.sqrt(np.where(ok, te_f, 0.0) ** 2 + horizon**2 * u_var + model_var)
    report = {"filtered_offset_s": te_f, "holdover_ready": locked >= ready,
              "holdover_sigma_s": np.where(new == State.LOCKED, sigma, np.nan)}
    memory = {"state": new, "run": run, "te_s1": s1, "te_s2": s2, "te_far": big, "u_f": u_f, "u_var": u_var,
              "locked": locked}
    return memory, reason, report


@dataclass(frozen=True)
class StateRun:
    """Per second (trials, steps), read-only: ``state`` and ``reason`` (int8), ``rail_alarm`` (the DAC near a
    rail), ``filtered_offset_s``, ``holdover_ready`` and ``holdover_sigma_s`` (NaN outside LOCKED or without a
    :class:`HoldoverModel`)."""

    state: np.ndarray
    reason: np.ndarray
    rail_alarm: np.ndarray
    filtered_offset_s: np.ndarray | None = None
    holdover_ready: np.ndarray | None = None
    holdover_sigma_s: np.ndarray | None = None

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


def run_states(usable, offset_s, config: StateConfig = StateConfig(), *, alarm=None, near_rail=None, implausible=None,
               freq_adj=None, reference_variance_s2=None, unresolved_s=None, fast: bool = True) -> StateRun:
    """States of (trials, steps) loops from their usable mask, measured offsets, alarms, refusals, DAC rails,
    frequency corrections, the fused reference's variance and its unresolved offset's bound (each (trials,
    steps), optional but the first two).

    ``fast``: the compiled :func:`~.kernels.states_kernel`; otherwise :func:`advance` second by second
    (its readable twin; tested equal)."""
    usable = np.asarray(usable, dtype=bool)
    if usable.ndim != 2:
        raise ValueError(f"usable has shape {usable.shape}, must have 2 dimension(s)")
    offset = check_array(offset_s, "offset_s", ndim=2, allow_nan=True)
    shape = usable.shape

    def mask(a):
        return np.zeros(shape, bool) if a is None else np.ascontiguousarray(np.broadcast_to(np.asarray(a, bool), shape))

    alarm, near, implausible = mask(alarm), mask(near_rail), mask(implausible)
    u = np.zeros(shape) if freq_adj is None else np.ascontiguousarray(np.broadcast_to(np.asarray(freq_adj, float), shape))
    ref_var = (np.zeros(shape) if reference_variance_s2 is None
               else np.ascontiguousarray(np.broadcast_to(np.asarray(reference_variance_s2, float), shape)))
    unresolved = (np.zeros(shape) if unresolved_s is None
                  else np.ascontiguousarray(np.nan_to_num(np.broadcast_to(np.asarray(unresolved_s, float), shape))))
    trials, steps = shape
    if fast:
        out = states_kernel(usable, alarm, implausible, near, np.ascontiguousarray(offset), u, ref_var, unresolved,
                            config.kernel_params())
        return StateRun(out[0], out[1], near.copy(), out[2], out[3] != 0, out[4])
    memory = initial_memory(trials)
    states = np.empty(shape, dtype=np.int8)
    reasons = np.empty(shape, dtype=np.int8)
    te_f, ready, sigma = np.empty(shape), np.empty(shape, bool), np.empty(shape)
    for k in range(steps):
        memory, reasons[:, k], rep = advance(memory, usable[:, k], offset[:, k], config, alarm=alarm[:, k],
                                             implausible=implausible[:, k], near_rail=near[:, k], freq_adj=u[:, k],
                                             reference_variance_s2=ref_var[:, k], unresolved_s=unresolved[:, k])
        states[:, k] = memory["state"]
        te_f[:, k], ready[:, k], sigma[:, k] = rep["filtered_offset_s"], rep["holdover_ready"], rep["holdover_sigma_s"]
    return StateRun(states, reasons, near.copy(), te_f, ready, sigma)


class StateMachine:
    """Streaming state of one GPSDO; :meth:`step` returns ``(State, Reason)`` for the second (the filtered
    time error and holdover report of the second in :attr:`report`)."""

    def __init__(self, config: StateConfig = StateConfig()):
        self.config = config
        self.reset()

    def reset(self) -> None:
        self._memory = initial_memory(1)
        self.report: dict = {}

    def step(self, usable: bool, offset_s: float, alarm: bool = False, *, implausible: bool = False,
             near_rail: bool = False, freq_adj: float = 0.0, reference_variance_s2: float = math.nan,
             unresolved_s: float = 0.0) -> tuple[State, Reason]:
        self._memory, reason, rep = advance(self._memory, np.array([bool(usable)]), np.array([float(offset_s)]),
                                            self.config, alarm=np.array([bool(alarm)]),
                                            implausible=np.array([bool(implausible)]),
                                            near_rail=np.array([bool(near_rail)]), freq_adj=np.array([float(freq_adj)]),
                                            reference_variance_s2=np.array([float(reference_variance_s2)]),
                                            unresolved_s=np.array([float(unresolved_s)]))
        self.report = {k: v[0].item() for k, v in rep.items()}
        return State(int(self._memory["state"][0])), Reason(int(reason[0]))
