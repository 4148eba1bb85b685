"""Closing the loop: a simulated oscillator disciplined by a servo to a GNSS reference, over trials.

The oscillator truth model is linear in its EFC input (``chronofuse.models.oscillator``: the EFC term
adds ``efc_gain V_q[n]`` to the frequency, zero-order hold), so the disciplined phase is the free-running
phase plus the integral of the applied corrections and the phase steps::

    x_k = x_free_k + c_k,   c_{k+1} = c_k + s_k + dt u_k

with ``u_k`` the DAC-applied correction and ``s_k`` the phase step of second ``k``. Each second the
servo sees ``z_k = x_k - e_k`` (``e_k``: the reference 1PPS error, NaN when unusable), optionally as
a time-interval counter reads it (quantized by the multi-phase counter, :mod:`.counter`). All trials
advance together (vectorized over the first axis); the servo's own functional core does the work, so
a loop run equals a streaming servo fed the same offsets (tested). With ``servo.fast`` (and no
counter) the whole loop runs in the compiled :func:`~.servo_kernel.close_loop_kernel` with the servo's
own backend kernel, the same arithmetic per loop as the servo's numpy core (tested against it).

``x_k`` is the time error of the regenerated 1PPS against true time (s): what the GPSDO delivers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.discipline.counter import MultiPhaseCounter
from chronofuse.discipline.servo_kernel import close_loop_kernel
from chronofuse.discipline.servo import Servo, freeze
from chronofuse.validation import check_array

__all__ = ["LoopRun", "close_loop"]


@dataclass(frozen=True)
class LoopRun:
    """A closed-loop run; arrays (trials, steps), read-only.

    ``phase_s``: disciplined 1PPS time error ``x_k``; ``offset_s``: what the servo measured (NaN when
    no usable reference); ``freq_adj``, ``phase_step_s``, ``offset_estimate_s``, ``innovation_s``,
    ``used``, ``near_rail``, ``servo_state``: the servo's outputs (see :class:`~.servo.ServoRun`).
    """

    phase_s: np.ndarray
    offset_s: np.ndarray
    freq_adj: np.ndarray
    phase_step_s: np.ndarray
    offset_estimate_s: np.ndarray
    innovation_s: np.ndarray
    used: np.ndarray
    near_rail: np.ndarray
    interval_s: float
    servo_state: np.ndarray | None = None

    def __post_init__(self):
        freeze(self)


def close_loop(servo: Servo, free_phase_s, reference_error_s, *, counter: MultiPhaseCounter | None = None,
               seed=None) -> LoopRun:
    """Discipline ``free_phase_s`` (trials, steps) to a reference whose 1PPS errs by ``reference_error_s``.

    ``reference_error_s``: shape (trials, steps) or (steps,) (one reference for every trial), NaN
    where no usable reference exists. ``counter``: read each offset with this multi-phase counter (its
    start phase uniform from ``numpy.random.default_rng(seed)``); None: exact offsets.
    """
    if not isinstance(servo, Servo):
        raise TypeError(f"servo == {servo!r}, must be a Servo")
    free = check_array(free_phase_s, "free_phase_s", ndim=2)
    ref = check_array(reference_error_s, "reference_error_s", ndim=(1, 2), allow_nan=True)
    trials, steps = free.shape
    if ref.shape not in ((steps,), (trials, steps)):
        raise ValueError(f"reference_error_s has shape {ref.shape}, must be ({steps},) or ({trials}, {steps})")
    ref = np.broadcast_to(ref, free.shape)
    dt = float(servo.interval_s)
    rng = np.random.default_rng(seed) if counter is not None else None

    state = servo.initial_state(trials)
    if servo._compiled() and counter is None:
        phase, offset, outs = close_loop_kernel(type(servo).kernel, np.ascontiguousarray(free), np.ascontiguousarray(ref),
                                                state["common"], state["kernel"], servo._kernel_params(),
                                                servo._policy())
        return LoopRun(phase, offset, outs[0], outs[1], outs[2], outs[3], outs[4] != 0.0, outs[5] != 0.0,
                       interval_s=dt, servo_state=outs[6].astype(np.int8))
    phase = np.empty((trials, steps))
    offset = np.empty((trials, steps))
    outs = [np.empty((trials, steps), dtype=d) for d in (float, float, float, float, bool, bool, np.int8)]
    c = np.zeros(trials)
    for k in range(steps):
        x = free[:, k] + c
        phase[:, k] = x
        z = x - ref[:, k]
        valid = np.isfinite(z)
        if counter is not None:
            # The counter measures a positive interval: offset it by one second and subtract again.
            z = np.where(valid, counter.measure_interval_s(1.0 + np.where(valid, z, 0.0), rng.random(trials)) - 1.0, z)
        offset[:, k] = z
        state, out = servo.update(state, z, valid, local_ts_s=k * dt)
        for dst, src in zip(outs, out):
            dst[:, k] = src
        c = c + out[1] + dt * out[0]
    return LoopRun(phase, offset, *outs[:6], interval_s=dt, servo_state=outs[6])
