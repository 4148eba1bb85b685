"""One servo interface for every loop controller, modelled on linuxptp's ``servo.h``.

linuxptp's servo is ``sample(offset, local_ts, weight) -> (adjustment, state)`` plus ``reset``; the
step-versus-slew policy lives in one shared place, the backends (``pi.c``, ``linreg.c``, ``nullf.c``)
only compute an adjustment. Here, per second ``k`` and for ``N`` independent loops (trials) at once:

* input: the measured offset ``z_k = x_k - e_k`` (s): the disciplined oscillator's 1PPS minus the
  (fused, qErr-corrected) GNSS 1PPS, NaN when no usable reference exists this second;
* output: the fractional-frequency correction applied over ``[k, k+1)`` (after the DAC: quantized and
  clipped at the rails), a phase step to apply to the regenerated 1PPS now (0 unless the servo jumps),
  the servo's estimate of its offset after the update, the innovation, whether the sample was used
  and whether the DAC is near a rail.

Step policy (shared, as in linuxptp's ``servo.c`` with its ``first_step_threshold``): the first usable
sample, and the first usable sample after a stretch without any whose ``|z| > step_threshold_s``, steps
the regenerated 1PPS by ``-z`` ("jam sync") instead of slewing; the backend is told the shift so that
its phase state follows. While the reference is continuous it never steps (a single outlier must not
move the 1PPS). ``step_threshold_s = None`` never steps.

Functional core: :meth:`Servo.update` maps ``(state, z, valid) -> (state', outputs)`` on arrays of
shape (N,) and returns new arrays (it never writes into the state it was given). :meth:`Servo.step`
(streaming, one loop) and :meth:`Servo.run` (batch replay over ``(trials, steps)``, e.g. of a recorded
run) both call it, so they agree to the last bit (tested). ``run`` never changes the object. Closing the
loop on a simulated oscillator is :func:`chronofuse.discipline.loop.close_loop`, on the same core.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.kernels import MODES, pack_params, servo_step_kernel, servo_step_packed
from chronofuse.validation import check_array, check_scalar

__all__ = ["Servo", "ServoOutput", "ServoRun", "NullServo", "freeze"]


def freeze(obj):
    """Make every ndarray field of a frozen dataclass a read-only view (returns ``obj``)."""
    for field in dataclasses.fields(obj):
        value = getattr(obj, field.name)
        if isinstance(value, np.ndarray):
            view = value.view()
            view.flags.writeable = False
            object.__setattr__(obj, field.name, view)
    return obj


@dataclass(frozen=True)
class ServoOutput:
    """One second of one streaming servo: the correction applied (fractional frequency), the phase
    step (s), the offset estimate after the update (s), the innovation (s, NaN when unused), whether
    the sample was used, whether the DAC is near a rail."""

    freq_adj: float
    phase_step_s: float
    offset_estimate_s: float
    innovation_s: float
    used: bool
    near_rail: bool


@dataclass(frozen=True)
class ServoRun:
    """What :meth:`Servo.run` returns; every array has shape (trials, steps) and is read-only."""

    freq_adj: np.ndarray
    phase_step_s: np.ndarray
    offset_estimate_s: np.ndarray
    innovation_s: np.ndarray
    used: np.ndarray
    near_rail: np.ndarray

    def __post_init__(self):
        freeze(self)


class Servo:
    """Base class: the shared step policy and DAC, the streaming and batch paths.

    Backends implement ``_initial(n) -> dict`` (their state for ``n`` loops) and
    ``_control(state, z, valid, shift) -> (state', y_cmd, offset_estimate, innovation, used)``, all on
    (n,) arrays, where ``shift`` is the phase step just applied (s) and ``state["u"]`` holds the
    correction actually applied over the previous second.

    Parameters (shared)
    -------------------
    interval_s : float, > 0 — the sample interval.
    dac : Dac or None — quantize and clip the corrections (None: ideal actuator).
    step_threshold_s : float or None — see the module docstring.
    fast : bool — use the compiled kernel (True) or the numpy twin (False); they agree to rounding.
    """

    name = "servo"

    def __init__(self, *, interval_s: float = 1.0, dac: Dac | None = None, step_threshold_s: float | None = 1e-6,
                 fast: bool = True):
        self.interval_s = interval_s
        self.dac = dac
        self.step_threshold_s = step_threshold_s
        self.fast = fast

    # -- the functional core ---------------------------------------------------------------------------

    def _check(self) -> None:
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        if self.dac is not None and not isinstance(self.dac, Dac):
            raise TypeError(f"dac == {self.dac!r}, must be a Dac or None")
        if self.step_threshold_s is not None:
            check_scalar(self.step_threshold_s, "step_threshold_s", min_val=0.0)

    def initial_state(self, n: int) -> dict[str, np.ndarray]:
        """State of ``n`` fresh loops: the backend's plus ``u`` (last applied correction) and ``started``."""
        self._check()
        state = self._initial(int(n))
        state["u"] = np.zeros(int(n))
        state["started"] = np.zeros(int(n), dtype=bool)
        state["prev_valid"] = np.zeros(int(n), dtype=bool)
        return state

    def update(self, state: dict, offset_s: np.ndarray, valid: np.ndarray):
        """One second for ``N`` loops: returns ``(state', (freq_adj, phase_step_s, estimate, innovation, used, near_rail))``.

        ``offset_s`` (N,) measured offsets (s; ignored where ``valid`` is False), ``valid`` (N,) bool.
        With ``fast`` the compiled kernel (:mod:`.kernels`) does the arithmetic of :meth:`_numpy_update`.
        """
        if self.fast:
            new = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in state.items()}
            out = servo_step_kernel(np.asarray(offset_s, dtype=np.float64), np.asarray(valid, dtype=bool),
                                    *self._kernel_arrays(new), *self._kernel_params(new))
            return new, (out[0], out[1], out[2], out[3], out[4] != 0.0, out[5] != 0.0)
        return self._numpy_update(state, offset_s, valid)

    def _kernel_arrays(self, state: dict) -> tuple:
        """The kernel's in-place state arrays (x, P, u, started, prev_valid, window, rejects, integral), dummies if unused."""
        n = state["u"].shape[0]
        return (state.get("x", np.zeros((n, 1))), state.get("P", np.zeros((n, 1, 1))), state["u"], state["started"],
                state["prev_valid"],
                state.get("window", np.zeros((n, 1))), state.get("rejects", np.zeros(n, dtype=np.int64)),
                state.get("integral", np.zeros(n)))

    def _kernel_params(self, state: dict) -> tuple:
        """The kernel's parameters (see :func:`.kernels.servo_step_kernel`); backends override their part."""
        return self._kernel_model(state) + self._kernel_tail()

    def _kernel_model(self, state: dict) -> tuple:
        """(F, Q, h, r, mode, dt, steer, step_thr, wakf_th, lam_min, lam_max, gamma, max_rejects, huber_c, kp, ki)."""
        one = np.zeros((1, 1))
        return (one, one, np.zeros(1), 1.0, MODES[self.name], float(self.interval_s), 1.0, self._step_thr(),
                0.0, 1.0, 1.0, 0.0, 0, 1.0, 0.0, 0.0)

    def _step_thr(self) -> float:
        return -1.0 if self.step_threshold_s is None else float(self.step_threshold_s)

    def _kernel_tail(self) -> tuple:
        """The DAC's parameters: (dac_on, gain, step_V, half, half_span, margin)."""
        if self.dac is None:
            return (False, 1.0, 1.0, 1.0, 1.0, 0.0)
        d = self.dac
        return (True, float(d.efc_gain_per_V), float(d.step_V), 2.0 ** (int(d.bits) - 1), 0.5 * float(d.range_V),
                float(d.rail_margin))

    def _numpy_update(self, state: dict, offset_s: np.ndarray, valid: np.ndarray):
        """The readable numpy core (the kernels' twin)."""
        z = np.where(valid, offset_s, 0.0)
        jump = valid & ~state["started"]
        if self.step_threshold_s is not None:
            jump = jump | (valid & ~state["prev_valid"] & (np.abs(z) > self.step_threshold_s))
        else:
            jump = np.zeros_like(jump)
        step = np.where(jump, -z, 0.0)
        z = z + step
        new, y_cmd, estimate, innovation, used = self._control(state, z, valid, step)
        if self.dac is None:
            applied, near = y_cmd, np.zeros(y_cmd.shape, dtype=bool)
        else:
            applied, near = self.dac.apply(y_cmd)
        new["u"] = applied
        new["started"] = state["started"] | valid
        new["prev_valid"] = np.asarray(valid, dtype=bool).copy()
        return new, (applied, step, estimate, innovation, used, near)

    # -- streaming -------------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget everything: the next :meth:`step` starts a fresh loop."""
        self._state = self.initial_state(1)
        self._packed = None

    def _pack(self) -> tuple:
        """The streaming state's arrays (shared, advanced in place) and the packed parameters."""
        params = self._kernel_params(self._state)
        self._out = np.empty(6)
        return (*self._kernel_arrays(self._state), *params[:3], pack_params(params[3:]))

    def step(self, offset_s: float | None) -> ServoOutput:
        """Take one measured offset (s; NaN or None = no usable reference this second).

        With ``fast``, the compiled per-loop function advances the streaming state in place (the same
        arithmetic as :meth:`update`, so step and run agree to the last bit)."""
        if not hasattr(self, "_state"):
            self.reset()
        z = math.nan if offset_s is None else float(offset_s)
        valid = math.isfinite(z)
        if self.fast:
            if self._packed is None:
                self._packed = self._pack()
            out = self._out
            servo_step_packed(z, valid, *self._packed, out)
            return ServoOutput(float(out[0]), float(out[1]), float(out[2]), float(out[3]), out[4] != 0.0,
                               out[5] != 0.0)
        self._state, out = self.update(self._state, np.array([z]), np.array([valid]))
        self._packed = None
        return ServoOutput(*(float(a[0]) if a.dtype != bool else bool(a[0]) for a in out))

    # -- batch -----------------------------------------------------------------------------------------

    def run(self, offset_s) -> ServoRun:
        """Replay measured offsets of shape (trials, steps) (NaN = missing); the object is unchanged."""
        z = check_array(offset_s, "offset_s", ndim=2, allow_nan=True)
        trials, steps = z.shape
        state = self.initial_state(trials)
        outs = [np.empty((trials, steps), dtype=d) for d in (float, float, float, float, bool, bool)]
        valid_all = np.isfinite(z)
        for k in range(steps):
            state, out = self.update(state, z[:, k], valid_all[:, k])
            for dst, src in zip(outs, out):
                dst[:, k] = src
        return ServoRun(*outs)


class NullServo(Servo):
    """The do-nothing baseline (linuxptp's ``nullf.c``): never corrects, never steps: the free-running
    oscillator, against which every controller's gain is measured."""

    name = "null"

    def __init__(self, *, interval_s: float = 1.0, dac: Dac | None = None, fast: bool = True):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=None, fast=fast)

    def _initial(self, n):
        return {}

    def _control(self, state, z, valid, shift):
        zeros = np.zeros(z.shape)
        return {}, zeros, np.where(valid, z, np.nan), np.where(valid, z, np.nan), valid.copy()
