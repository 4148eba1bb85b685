"""A proportional-only servo: ``y_k = -kp z_k / dt``, steering the phase and holding no frequency memory.

Under a constant oscillator frequency offset ``y_osc`` it settles at the phase error ``dt y_osc / kp``
(a type-1 loop), which is why real GPSDOs add an integrator; as a plugin it shows the whole of what a
servo needs: the numpy core, the compiled backend of the shared kernel interface, a config with units and
the registry entry.
"""

import math

import numba
import numpy as np
from pydantic import Field

from chronofuse.discipline.servo import Servo
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.registry import Config, Entry


@numba.njit(SAMPLE, cache=False)
def sample_p(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    kp, dt = params[0], params[1]
    used = not math.isnan(offset_s)
    out[0] = offset_s
    out[1] = offset_s
    out[2] = 1.0 if used else 0.0
    if used:
        state[0] = -kp * offset_s / dt
    return state[0]  # without a sample: the last correction held


class ProportionalConfig(Config):
    kp: float = Field(0.05, gt=0.0, lt=2.0, description="proportional gain per sample (dimensionless)")


class ProportionalServo(Servo):
    name = "example-p"
    kernel = sample_p

    def __init__(self, kp=0.05, *, interval_s=1.0, dac=None, step_threshold_s=1e-6, fast=True):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=step_threshold_s, fast=fast)
        self.kp = kp

    def _initial(self, n):
        return {"y": np.zeros(n)}

    def _control(self, state, z, valid, shift, weight):
        y = np.where(valid, -self.kp * z / self.interval_s, state["y"])
        est = np.where(valid, z, np.nan)
        return {"y": y}, y, est, est.copy(), valid.copy()

    def _kernel_initial(self, n):
        return np.zeros((n, 1))

    def _kernel_params(self):
        return np.array([float(self.kp), float(self.interval_s)])


ENTRY = Entry(ProportionalServo, ProportionalConfig, "proportional-only servo (an example plugin)")
