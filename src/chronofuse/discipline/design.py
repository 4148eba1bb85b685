"""Loop design from what a designer knows: the measurement noise a GNSSDO's servo is set up for, the
clairvoyant servo that bounds every controller, and the white noise a slow loop sees in a real 1PPS record.

These are the controller design maths of the disciplined oscillator; :mod:`chronofuse.experiments.gnssdo`
only chooses which to use for a run.
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.discipline.bound import ClairvoyantServo, clairvoyant_servo
from chronofuse.discipline.dac import Dac
from chronofuse.models.environment import ReceiverEnvironment
from chronofuse.models.oscillator import OscillatorModel

__all__ = ["design_measurement_sigma_s", "clairvoyant_controller", "equivalent_white_sigma_s"]


def design_measurement_sigma_s(env: ReceiverEnvironment, receivers: int, interval_s: float = 1.0) -> float:
    """The designer's white measurement noise (s) for the fused reference: white noise plus the multipath
    as the white noise it looks like to a loop much slower than its correlation time (a Gauss-Markov
    process has zero-frequency spectral density ``2 sigma^2 tau``, Brown and Hwang ch. 2, i.e. a
    per-sample variance ``2 sigma^2 tau / dt``), divided by the number of receivers. The slow wander
    is left out: no loop can tell it from the oscillator."""
    m = env.model
    return math.sqrt((m.white_sigma_s**2 + 2.0 * m.multipath_sigma_s**2 * m.multipath_tau_s / interval_s) / receivers)


def clairvoyant_controller(osc: OscillatorModel, env: ReceiverEnvironment, receivers: int,
                           dac: Dac | None) -> ClairvoyantServo:
    """The optimality yardstick, :func:`chronofuse.discipline.bound.clairvoyant_servo`: the true models of
    the oscillator (flicker FM included) and of the fused reference's noise, unconstrained steering."""
    return clairvoyant_servo(osc, env, receivers, dac)


def equivalent_white_sigma_s(e: np.ndarray, block_s: int = 100) -> float:
    """The white noise (s) a slow loop sees in a 1PPS error record ``e`` (1 Hz): ``sqrt(B var(dm) / 2)`` with
    ``dm`` the differences of consecutive ``B``-second block means (for white noise of variance
    ``sigma^2`` that is ``sigma``; for short-correlated noise it is its zero-frequency level, the
    ``2 sigma^2 tau`` of :func:`design_measurement_sigma_s`; differencing removes the slow wander)."""
    n = e.size // block_s * block_s
    means = e[:n].reshape(-1, block_s).mean(axis=1)
    return float(np.sqrt(block_s * np.var(np.diff(means)) / 2.0))
