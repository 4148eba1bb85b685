"""A jump detector: a first difference of the clock bias far from the training's, robustly scaled.

``d(k) = x(k) - x(k-1)``; the training gives its median ``m`` and ``s = 1.4826 MAD``; epoch ``k`` alarms when
``|d(k) - m| / s > z``, ``z = Phi^-1(1 - P_fa / 2)``. It sees a clock step as one alarm, which the
second-difference tests see as two.
"""

import math
from typing import ClassVar

import numpy as np
from pydantic import Field
from scipy import stats

from chronofuse.integrity.result import DetectionResult, StepOutput
from chronofuse.registry import Config, Entry


class JumpConfig(Config):
    pfa: float = Field(1e-3, gt=0.0, lt=1.0, description="false-alarm probability per epoch (dimensionless)")


class JumpDetector:
    inputs: ClassVar[tuple[str, ...]] = ()
    window: ClassVar[int] = 1

    def __init__(self, *, interval_s, pfa=1e-3):
        self.interval_s = interval_s
        self.pfa = pfa

    def fit(self, clock_bias_s=None):
        if clock_bias_s is None:
            raise ValueError("the jump detector learns its scale: fit() needs a training stretch (--train)")
        d = np.diff(np.asarray(clock_bias_s, dtype=float))
        d = d[np.isfinite(d)]
        self.median_ = float(np.median(d))
        self.scale_ = float(1.4826 * np.median(np.abs(d - self.median_)))
        self.threshold_ = float(stats.norm.isf(self.pfa / 2.0))
        self.reset()
        return self

    def run(self, clock_bias_s):
        x = np.asarray(clock_bias_s, dtype=float)
        d = np.full(x.shape, np.nan)
        d[..., 1:] = np.diff(x, axis=-1)
        stat = np.abs(d - self.median_) / self.scale_
        dof = np.isfinite(stat).astype(np.int64)
        return DetectionResult.from_statistic(stat, dof, np.where(dof > 0, self.threshold_, np.nan), x, 1, self.pfa)

    def reset(self):
        self._prev = math.nan

    def step(self, clock_bias_s):
        x = math.nan if clock_bias_s is None else float(clock_bias_s)
        d, self._prev = x - self._prev, x
        if math.isnan(d):
            return StepOutput(math.nan, False, 0, math.nan, math.isnan(x))
        stat = abs(d - self.median_) / self.scale_
        return StepOutput(stat, stat > self.threshold_, 1, self.threshold_, False)


ENTRY = Entry(JumpDetector, JumpConfig, "first-difference jump detector (an example plugin)")
