"""The do-nothing servo (linuxptp's ``nullf.c``): never corrects, never steps.

Its output is the free-running oscillator, against which every controller's gain is measured; its offset
estimate and innovation are the measured offset itself. One module, as every servo: the numpy core, the
compiled backend and the registry config.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.registry import Config

__all__ = ["NullServo", "NullServoConfig", "sample_null"]


@numba.njit(SAMPLE, cache=True)
def sample_null(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel (:data:`~chronofuse.discipline.servo_kernel.SAMPLE`): no adjustment, the offset as estimate."""
    out[0] = offset_s
    out[1] = offset_s
    out[2] = 0.0 if math.isnan(offset_s) else 1.0
    return 0.0


class NullServoConfig(Config):
    """The null servo has no setting."""


class NullServo(Servo):
    """The do-nothing baseline (module docstring)."""

    name = "null"
    kernel = sample_null

    def __init__(self, *, interval_s: float = 1.0, dac: Dac | None = None, fast: bool = True):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=None, fast=fast)

    def _initial(self, n):
        return {}

    def _control(self, state, z, valid, shift, weight):
        zeros = np.zeros(z.shape)
        return {}, zeros, np.where(valid, z, np.nan), np.where(valid, z, np.nan), valid.copy()

    def _kernel_initial(self, n):
        return np.zeros((n, 0))

    def _kernel_params(self):
        return np.zeros(1)
