"""One servo interface for every loop controller, modelled on linuxptp's ``servo.h``, on the estimation interface.

linuxptp's servo is ``sample(offset, local_ts, weight) -> (adjustment, state)`` plus ``reset``; the
step-versus-slew policy and the state enum live in one shared place, the backends (``pi.c``, ``linreg.c``,
``nullf.c``) only compute an adjustment. Here, per second ``k`` and for ``N`` independent loops (trials):

* input: the measured offset ``z_k = x_k - e_k`` (s): the disciplined oscillator's 1PPS minus the
  (fused, qErr-corrected) GNSS 1PPS, NaN when no usable reference exists this second; optionally its
  ``weight`` (information relative to the nominal, 1 by default);
* output (:class:`ServoOutput`, :class:`ServoRun`): the fractional-frequency correction applied over
  ``[k, k+1)`` (after the DAC: quantized and clipped at the rails), a phase step to apply to the
  regenerated 1PPS now (0 unless the servo jumps), the servo's offset estimate after the update, the
  innovation, whether the sample was used, whether the DAC is near a rail, and the servo state
  (:class:`ServoState`).

Step policy (shared, as in linuxptp's ``servo.c`` with its ``first_step_threshold``): the first usable
sample, and the first usable sample after a stretch without any whose ``|z| > step_threshold_s``, steps
the regenerated 1PPS by ``-z`` ("jam sync") instead of slewing; the backend is told the shift so that
its phase estimate follows (on the very first sample there is no estimate yet, and the shift told is 0).
While the reference is continuous it never steps (a single outlier must not move the 1PPS).
``step_threshold_s = None`` never steps.

States (:class:`ServoState`, promoted in the shared code only): ``UNLOCKED`` before the first usable
sample, ``JUMP`` on a second that stepped, ``TRACKING`` when the sample steered the loop, ``HOLDOVER``
when there was none (or the servo rejected it) and the servo steers on its own prediction. Whether the
loop is *locked* (its error within limits for long enough) is the GPSDO state machine's verdict
(:mod:`.states`), not the servo's.

A servo is an estimator (:mod:`chronofuse.estimation.interface`): ``__init__`` stores its arguments,
:meth:`Servo.fit` learns from a recorded stretch what the servo can learn (the Kalman servos: the
oscillator's and the reference's noise, :meth:`~chronofuse.discipline.kalman.KalmanServo.fit`) and resets,
:meth:`Servo.step` takes one second of one loop, :meth:`Servo.run` replays ``(trials, steps)`` without
changing the object and returns a frozen, read-only :class:`ServoRun`. A servo whose parameters are all
given needs no fit. Closing the loop on a simulated oscillator is :func:`chronofuse.discipline.loop.close_loop`.

Adding a servo is one module and one registry entry (:mod:`chronofuse.discipline.registry`): a subclass
with the readable numpy core (``_initial``, ``_control``) and, for speed, its compiled backend
(``kernel``: a numba function of :data:`chronofuse.discipline.servo_kernel.SAMPLE`, with
``_kernel_initial`` and ``_kernel_params``). With ``fast=True`` (the default) the backend runs inside the
shared compiled policy (:mod:`.servo_kernel`); with ``fast=False``, or when a class has no ``kernel``, the
numpy core runs inside :meth:`Servo.update`'s numpy policy. Tests compare the two for every servo.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from enum import IntEnum
from typing import ClassVar

import numpy as np

from chronofuse.discipline import servo_kernel as sk
from chronofuse.discipline.dac import Dac
from chronofuse.estimation.interface import FrozenResult
from chronofuse.validation import check_array, check_scalar

__all__ = ["Servo", "ServoOutput", "ServoRun", "ServoState", "freeze", "open_loop_offset_s"]


def freeze(obj):
    """Make every ndarray field of a frozen dataclass a read-only view (returns ``obj``)."""
    for field in dataclasses.fields(obj):
        value = getattr(obj, field.name)
        if isinstance(value, np.ndarray):
            view = value.view()
            view.flags.writeable = False
            object.__setattr__(obj, field.name, view)
    return obj


class ServoState(IntEnum):
    """What the servo did with a second's sample (module docstring); the compiled values are in :mod:`.servo_kernel`."""

    UNLOCKED = int(sk.UNLOCKED)
    JUMP = int(sk.JUMP)
    TRACKING = int(sk.TRACKING)
    HOLDOVER = int(sk.HOLDOVER)


@dataclass(frozen=True)
class ServoOutput:
    """One second of one streaming servo: the correction applied (fractional frequency), the phase
    step (s), the offset estimate after the update (s), the innovation (s, NaN when unused), whether
    the sample was used, whether the DAC is near a rail, and the servo state."""

    freq_adj: float
    phase_step_s: float
    offset_estimate_s: float
    innovation_s: float
    used: bool
    near_rail: bool
    servo_state: ServoState = ServoState.UNLOCKED


@dataclass(frozen=True)
class ServoRun(FrozenResult):
    """What :meth:`Servo.run` returns; every array has shape (trials, steps) and is read-only
    (``servo_state`` int8, the values of :class:`ServoState`)."""

    freq_adj: np.ndarray
    phase_step_s: np.ndarray
    offset_estimate_s: np.ndarray
    innovation_s: np.ndarray
    used: np.ndarray
    near_rail: np.ndarray
    servo_state: np.ndarray


#: The states by value (indexing this tuple is cheaper than calling the enum in the streaming step).
_STATES = tuple(ServoState)

#: The dtypes of the seven outputs, in :data:`.servo_kernel.N_OUT` order.
_OUT_DTYPES = (float, float, float, float, bool, bool, np.int8)


def open_loop_offset_s(offset_s, freq_adj=None, phase_step_s=None, interval_s: float = 1.0) -> np.ndarray:
    """The offsets a free-running oscillator would have shown: ``z_k - c_k`` with ``c_k = sum_{j<k} (s_j + dt u_j)``.

    A closed loop adds its corrections ``u`` (held over each interval) and phase steps ``s`` to the
    oscillator, so ``z_k - c_k = x_free_k - e_k``: the free oscillator against the reference, which is
    what a noise model is fitted to. ``offset_s``, ``freq_adj``, ``phase_step_s``: (steps,) or (trials,
    steps), NaN offsets allowed (None: zeros, an open-loop record)."""
    z = check_array(offset_s, "offset_s", ndim=(1, 2), allow_nan=True)
    inc = np.zeros(z.shape)
    for name, value, scale in (("freq_adj", freq_adj, interval_s), ("phase_step_s", phase_step_s, 1.0)):
        if value is not None:
            v = check_array(value, name, ndim=z.ndim)
            if v.shape != z.shape:
                raise ValueError(f"{name} has shape {v.shape}, must equal offset_s's {z.shape}")
            inc = inc + scale * v
    c = np.zeros(z.shape)
    np.cumsum(inc[..., :-1], axis=-1, out=c[..., 1:])
    return z - c


class Servo:
    """Base class: the shared step policy, DAC and state, the estimator interface, streaming and batch paths.

    Subclasses implement the numpy core ``_initial(n) -> dict`` (their state for ``n`` loops) and
    ``_control(state, z, valid, shift, weight) -> (state', y_cmd, offset_estimate, innovation, used)`` on
    (n,) arrays, where ``shift`` is the phase step just applied (s) and ``state["u"]`` holds the correction
    actually applied over the previous second; and, for the compiled path, the class attribute ``kernel``
    with ``_kernel_initial(n) -> (n, S)`` and ``_kernel_params() -> (P,)`` float64 arrays. ``_learn(z_open,
    interval_s)`` is what :meth:`fit` asks a subclass to learn (default: nothing).

    Parameters (shared)
    -------------------
    interval_s : float, > 0 — the sample interval.
    dac : Dac or None — quantize and clip the corrections (None: ideal actuator).
    step_threshold_s : float or None — see the module docstring.
    fast : bool — the compiled backend (True) or the numpy core (False); they agree to rounding.
    """

    name = "servo"
    inputs: ClassVar[tuple[str, ...]] = ()
    kernel = None

    def __init__(self, *, interval_s: float = 1.0, dac: Dac | None = None, step_threshold_s: float | None = 1e-6,
                 fast: bool = True):
        self.interval_s = interval_s
        self.dac = dac
        self.step_threshold_s = step_threshold_s
        self.fast = fast

    # -- learning ---------------------------------------------------------------------------------------

    def fit(self, offset_s=None, *, freq_adj=None, phase_step_s=None) -> Servo:
        """Learn what this servo can learn from a recorded stretch, then reset; returns self.

        ``offset_s`` (steps,) or (trials, steps): measured offsets (s, NaN = missing), recorded open loop or
        under any loop whose applied corrections ``freq_adj`` and phase steps ``phase_step_s`` are given
        (a :class:`~chronofuse.discipline.loop.LoopRun` has all three); they are turned into the free
        oscillator's offsets by :func:`open_loop_offset_s`. ``None``: nothing to learn from (the parameters
        must all be given). What is learnt ends in ``_`` (see the subclass); given parameters are kept.
        """
        self._check_shared()
        if offset_s is not None:
            z_open = open_loop_offset_s(offset_s, freq_adj, phase_step_s, float(self.interval_s))
            self._learn(np.atleast_2d(z_open), float(self.interval_s))
        self._check()
        self.reset()
        return self

    def _learn(self, z_open: np.ndarray, interval_s: float) -> None:
        """Learn from free-oscillator offsets (trials, steps); the base servo has nothing to learn."""

    # -- checks and the compiled path's constants --------------------------------------------------------

    def _check_shared(self) -> None:
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        if self.dac is not None and not isinstance(self.dac, Dac):
            raise TypeError(f"dac == {self.dac!r}, must be a Dac or None")
        if self.step_threshold_s is not None:
            check_scalar(self.step_threshold_s, "step_threshold_s", min_val=0.0)

    def _check(self) -> None:
        self._check_shared()

    def _policy(self) -> np.ndarray:
        """The shared policy's constants (see :mod:`.servo_kernel`)."""
        thr = -1.0 if self.step_threshold_s is None else float(self.step_threshold_s)
        if self.dac is None:
            dac = (0.0, 1.0, 1.0, 1.0, 1.0, 0.0)
        else:
            d = self.dac
            dac = (1.0, float(d.efc_gain_per_V), float(d.step_V), 2.0 ** (int(d.bits) - 1), 0.5 * float(d.range_V),
                   float(d.rail_margin))
        return np.array((float(self.interval_s), thr) + dac, dtype=np.float64)

    def _compiled(self) -> bool:
        return bool(self.fast) and type(self).kernel is not None

    def initial_state(self, n: int) -> dict[str, np.ndarray]:
        """State of ``n`` fresh loops for :meth:`update`.

        Compiled path: ``{"common": (n, 4), "kernel": (n, S)}``; numpy path: the backend's dict plus ``u``
        (last applied correction), ``started`` and ``prev_valid``."""
        self._check()
        n = int(n)
        if self._compiled():
            return {"common": np.zeros((n, sk.N_COMMON)),
                    "kernel": np.ascontiguousarray(self._kernel_initial(n), dtype=np.float64)}
        state = self._initial(n)
        state["u"] = np.zeros(n)
        state["started"] = np.zeros(n, dtype=bool)
        state["prev_valid"] = np.zeros(n, dtype=bool)
        return state

    # -- the functional core ------------------------------------------------------------------------------

    def update(self, state: dict, offset_s, valid, *, weight=None, local_ts_s: float = 0.0):
        """One second for ``N`` loops: returns ``(state', (freq_adj, phase_step_s, estimate, innovation, used,
        near_rail, servo_state))``, new arrays (``state`` is not modified).

        ``offset_s`` (N,) measured offsets (s; ignored where ``valid`` is False), ``valid`` (N,) bool,
        ``weight`` (N,) or None (1). ``state`` from :meth:`initial_state`.
        """
        z = np.asarray(offset_s, dtype=np.float64)
        valid = np.asarray(valid, dtype=bool)
        w = np.ones(z.shape) if weight is None else np.asarray(weight, dtype=np.float64)
        if self._compiled():
            new = {"common": state["common"].copy(), "kernel": state["kernel"].copy()}
            out = sk.tick_many(type(self).kernel, np.where(valid, z, np.nan), float(local_ts_s),
                               np.ascontiguousarray(w), new["common"], new["kernel"], self._kernel_params(),
                               self._policy())
            return new, (out[0], out[1], out[2], out[3], out[4] != 0.0, out[5] != 0.0, out[6].astype(np.int8))
        return self._numpy_update(state, z, valid, w)

    def _numpy_update(self, state: dict, offset_s: np.ndarray, valid: np.ndarray, weight: np.ndarray):
        """The readable numpy policy around the backend's numpy core (the compiled :func:`.servo_kernel.tick`'s twin)."""
        z = np.where(valid, offset_s, 0.0)
        started = state["started"]
        if self.step_threshold_s is not None:
            jump = valid & (~started | (~state["prev_valid"] & (np.abs(z) > self.step_threshold_s)))
        else:
            jump = np.zeros(z.shape, dtype=bool)
        step = np.where(jump, -z, 0.0)
        z = z + step
        shift = np.where(started, step, 0.0)  # the first sample sets the phase origin
        new, y_cmd, estimate, innovation, used = self._control(state, z, valid, shift, weight)
        if self.dac is None:
            applied, near = y_cmd, np.zeros(y_cmd.shape, dtype=bool)
        else:
            applied, near = self.dac.apply(y_cmd)
        servo_state = np.select([jump, used, started | valid], [ServoState.JUMP, ServoState.TRACKING,
                                                                ServoState.HOLDOVER], ServoState.UNLOCKED)
        new["u"] = applied
        new["started"] = started | valid
        new["prev_valid"] = valid.copy()
        return new, (applied, step, estimate, innovation, used, near, servo_state.astype(np.int8))

    # -- streaming -------------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the streaming state: the next :meth:`step` starts a fresh loop."""
        self._state = self.initial_state(1)
        self._k = 0
        if self._compiled():
            self._bound = (sk.streaming_step(type(self).kernel), self._kernel_params(), self._policy(),
                           np.empty(sk.N_OUT))

    def step(self, offset_s: float | None, *, weight: float = 1.0) -> ServoOutput:
        """Take one measured offset (s; NaN or None = no usable reference this second).

        The same arithmetic as :meth:`run` (step and run agree to the last bit)."""
        if not hasattr(self, "_state"):
            self.reset()
        z = math.nan if offset_s is None else float(offset_s)
        t = self._k * float(self.interval_s)
        self._k += 1
        if self._compiled():
            step, params, policy, out = self._bound
            step(z if math.isfinite(z) else math.nan, t, float(weight), self._state["common"], self._state["kernel"],
                 params, policy, out)
            o = out.tolist()
            return ServoOutput(o[0], o[1], o[2], o[3], o[4] != 0.0, o[5] != 0.0, _STATES[int(o[6])])
        self._state, out = self.update(self._state, np.array([z]), np.array([math.isfinite(z)]),
                                       weight=np.array([float(weight)]), local_ts_s=t)
        return ServoOutput(float(out[0][0]), float(out[1][0]), float(out[2][0]), float(out[3][0]), bool(out[4][0]),
                           bool(out[5][0]), ServoState(int(out[6][0])))

    # -- batch -----------------------------------------------------------------------------------------

    def run(self, offset_s, *, weight=None) -> ServoRun:
        """Replay measured offsets of shape (trials, steps) (NaN = missing); the object is unchanged.

        ``weight``: (trials, steps) or None (1 everywhere)."""
        z = check_array(offset_s, "offset_s", ndim=2, allow_nan=True)
        trials, steps = z.shape
        w = np.ones(z.shape) if weight is None else check_array(weight, "weight", ndim=2)
        if w.shape != z.shape:
            raise ValueError(f"weight has shape {w.shape}, must equal offset_s's {z.shape}")
        state = self.initial_state(trials)
        outs = [np.empty((trials, steps), dtype=d) for d in _OUT_DTYPES]
        valid_all = np.isfinite(z)
        for k in range(steps):
            state, out = self.update(state, z[:, k], valid_all[:, k], weight=w[:, k], local_ts_s=k * float(self.interval_s))
            for dst, src in zip(outs, out):
                dst[:, k] = src
        return ServoRun(*outs)
