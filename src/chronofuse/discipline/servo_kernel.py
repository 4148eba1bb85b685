"""The compiled servo interface: one backend kernel per servo, and the shared step policy, DAC and state.

linuxptp's servo is ``servo_sample(servo, offset, local_ts, weight, &state) -> adjustment`` with the
step-versus-slew decision and the state enum kept in one shared place (``servo.c``) and the backends
(``pi.c``, ``linreg.c``, ``nullf.c``) computing only an adjustment. Here the same split, compiled:

* a **backend kernel** is a numba function of the signature :data:`SAMPLE`::

      sample(offset_s, local_ts_s, weight, shift_s, applied, state, params, out) -> adjustment

  ``offset_s``: the measured offset after any phase step (s; NaN: no usable sample this second);
  ``local_ts_s``: the sample's time (s since the loop started); ``weight``: the sample's information
  relative to the nominal (1: nominal; the Kalman servos use ``R / weight``); ``shift_s``: the phase step
  the shared policy just applied to the regenerated 1PPS (s; the backend's phase estimate follows it);
  ``applied``: the correction actually applied over the previous interval (after the DAC; fractional
  frequency); ``state`` (S,): the backend's own state, advanced in place; ``params`` (P,): its constants.
  It writes ``out[0]`` its offset estimate after the sample (s), ``out[1]`` the innovation (s, NaN when
  the sample was not used), ``out[2]`` 1.0 if it used the sample, and returns the frequency adjustment
  it asks for over the next interval (fractional frequency, before the DAC);
* :func:`tick` wraps any backend with what every servo shares: the step policy (jam sync on the first
  sample and after a gap when ``|offset| > step_threshold_s``), the DAC (quantize, clip, near-rail
  flag) and the servo state (:class:`chronofuse.discipline.servo.ServoState`, promoted here and only here);
* :func:`close_loop_kernel` closes the loop on a simulated oscillator with any backend, :func:`tick_many`
  advances N loops by one second, :func:`streaming_step` gives one loop's step with the backend bound
  at compile time (a call from Python costs a fraction of a microsecond).

A backend is passed as a first-class function of the fixed type :data:`SAMPLE_FUNCTION`, so these
functions are compiled once (and cached) for every servo, built-in or plugin. The readable numpy twin of
all of this is :meth:`chronofuse.discipline.servo.Servo.update` with ``fast=False``; tests compare them.

Per-loop shared state (N, 4) ``common``: applied correction, started, previous sample valid, servo state.
``policy`` (8,): interval (s), step threshold (s; < 0: never step), DAC on, EFC gain (1/V), DAC step (V),
half the codes, half the span (V), rail margin. Outputs (7,) per loop and second: correction applied,
phase step (s), offset estimate (s), innovation (s), used, near rail, servo state.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np
from numba import types

__all__ = ["SAMPLE", "SAMPLE_FUNCTION", "N_COMMON", "N_OUT", "tick", "tick_many", "close_loop_kernel",
           "streaming_step", "UNLOCKED", "JUMP", "TRACKING", "HOLDOVER"]

_f8 = types.float64
_vec = types.float64[::1]
_mat = types.float64[:, ::1]
_in_mat = types.Array(types.float64, 2, "C", readonly=True)  # inputs the kernels only read
_in_vec = types.Array(types.float64, 1, "C", readonly=True)

#: The backend kernel's signature (module docstring).
SAMPLE = _f8(_f8, _f8, _f8, _f8, _f8, _vec, _vec, _vec)
#: The type a backend is passed as.
SAMPLE_FUNCTION = types.FunctionType(SAMPLE)

N_COMMON = 4
N_OUT = 7
# Servo states (the values of chronofuse.discipline.servo.ServoState).
UNLOCKED = 0.0
JUMP = 1.0
TRACKING = 2.0
HOLDOVER = 3.0


@numba.njit(types.void(SAMPLE_FUNCTION, _f8, _f8, _f8, types.int64, _mat, _mat, _vec, _in_vec, _vec), cache=True)
def tick(sample, offset_s, local_ts_s, weight, i, common, state, params, policy, out):
    """One second of loop ``i``: step policy, the backend ``sample``, DAC, state; writes ``out`` (7,)."""
    valid = not math.isnan(offset_s)
    z = offset_s if valid else 0.0
    started = common[i, 1] != 0.0
    step_thr = policy[1]
    jump = False
    if step_thr >= 0.0 and valid:
        jump = (not started) or (common[i, 2] == 0.0 and abs(z) > step_thr)
    s = -z if jump else 0.0
    z = z + s
    # The first sample sets the phase origin: there is no earlier estimate for the backend to move.
    shift = s if started else 0.0
    y = sample(z if valid else math.nan, local_ts_s, weight, shift, common[i, 0], state[i], params, out)
    used = out[2] != 0.0
    estimate = out[0]
    innovation = out[1]
    near = False
    if policy[2] != 0.0:
        gain, step_V, half, half_span, margin = policy[3], policy[4], policy[5], policy[6], policy[7]
        code = np.rint(y / gain / step_V)
        code = min(max(code, -half), half - 1.0)
        vq = code * step_V
        y = gain * vq
        near = abs(vq) >= half_span * (1.0 - margin) - step_V
    if jump:
        servo_state = JUMP
    elif used:
        servo_state = TRACKING
    elif started or valid:
        servo_state = HOLDOVER
    else:
        servo_state = UNLOCKED
    common[i, 0] = y
    common[i, 1] = 1.0 if (started or valid) else 0.0
    common[i, 2] = 1.0 if valid else 0.0
    common[i, 3] = servo_state
    out[0] = y
    out[1] = s
    out[2] = estimate
    out[3] = innovation
    out[4] = 1.0 if used else 0.0
    out[5] = 1.0 if near else 0.0
    out[6] = servo_state


@numba.njit(_mat(SAMPLE_FUNCTION, _in_vec, _f8, _in_vec, _mat, _mat, _vec, _in_vec), cache=True)
def tick_many(sample, offset_s, local_ts_s, weight, common, state, params, policy):
    """One second for N loops (``offset_s``, ``weight`` (N,)); state advanced in place; outputs (7, N)."""
    n_loops = offset_s.shape[0]
    outs = np.empty((N_OUT, n_loops))
    tmp = np.empty(N_OUT)
    for i in range(n_loops):
        tick(sample, offset_s[i], local_ts_s, weight[i], i, common, state, params, policy, tmp)
        for a in range(N_OUT):
            outs[a, i] = tmp[a]
    return outs


@numba.njit(types.Tuple((_mat, _mat, types.float64[:, :, ::1]))(SAMPLE_FUNCTION, _in_mat, _in_mat, _mat, _mat, _vec,
                                                                 _in_vec), cache=True)
def close_loop_kernel(sample, free, ref, common, state, params, policy):
    """The closed loop (:mod:`.loop`) over (trials, steps) with any backend; returns phase, offset, outputs (7, trials, steps).

    ``x_k = free_k + c_k``, ``z_k = x_k - ref_k``, ``c_{k+1} = c_k + s_k + dt u_k``."""
    trials, steps = free.shape
    dt = policy[0]
    phase = np.empty((trials, steps))
    offset = np.empty((trials, steps))
    outs = np.empty((N_OUT, trials, steps))
    tmp = np.empty(N_OUT)
    for i in range(trials):
        c = 0.0
        for k in range(steps):
            xk = free[i, k] + c
            phase[i, k] = xk
            zk = xk - ref[i, k]
            offset[i, k] = zk
            tick(sample, zk, k * dt, 1.0, i, common, state, params, policy, tmp)
            for a in range(N_OUT):
                outs[a, i, k] = tmp[a]
            c = c + tmp[1] + dt * tmp[0]
    return phase, offset, outs


@lru_cache(maxsize=None)
def streaming_step(sample):
    """``step(offset_s, local_ts_s, weight, common (1, 4), state (1, S), params, policy, out (7,))`` for one
    loop with ``sample`` bound at compile time (a dispatcher passed from Python costs ~0.1 ms per call;
    this costs well under a microsecond). Compiled on first use in each process (~0.1 s)."""

    @numba.njit
    def step(offset_s, local_ts_s, weight, common, state, params, policy, out):
        tick(sample, offset_s, local_ts_s, weight, 0, common, state, params, policy, out)

    return step
