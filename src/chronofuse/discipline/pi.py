"""PI servo on the phase offset (the GNSSDO paper eq. (4-3); linuxptp ``pi.c``).

Per second (``dt`` = interval), with measured offset ``z_k`` (s) and the integral ``I`` (a fractional
frequency)::

    I_k = I_{k-1} + ki z_k / dt
    y_k = -(kp z_k / dt + I_k)            correction applied over [k, k+1)

so it steers phase (the ``kp`` term) and frequency (``I`` converges to minus the oscillator's
frequency offset). Without a usable sample the servo holds ``y = -I`` (the last frequency).

Closed loop (phase ``x_{k+1} = x_k + dt (y_osc + y_k)``): the error obeys
``(z - 1)(z - 1 + kp) + ki z = 0``, i.e. ``z^2 - (2 - kp - ki) z + (1 - kp) = 0`` (stable for
``0 < ki``, ``0 < kp < 2``, ``2 kp + ki < 4``). Matching the continuous type-2 loop
``s^2 + 2 zeta w_n s + w_n^2`` (F. M. Gardner, *Phaselock Techniques*, 3rd ed., ch. 2) for
``w_n dt << 1`` gives ``kp = 2 zeta w_n dt``, ``ki = (w_n dt)^2`` (:meth:`PiServo.from_bandwidth`,
``w_n = 2 pi f_n``). The source paper's preset ``kp = 0.5``, ``ki = 0.1`` is ``w_n dt = 0.316``,
``zeta = 0.79``: a loop time constant ``1 / w_n`` of about 3 s, which passes the GNSS 1PPS noise
straight to the output (the measured consequence is in docs/gnssdo).
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.servo import Servo
from chronofuse.validation import check_scalar

__all__ = ["PiServo", "SEED_KP", "SEED_KI"]

SEED_KP = 0.5
SEED_KI = 0.1


class PiServo(Servo):
    """PI servo; ``kp``, ``ki`` dimensionless per-sample gains (defaults: the source paper's 0.5 and 0.1)."""

    name = "pi"

    def __init__(self, kp: float = SEED_KP, ki: float = SEED_KI, *, interval_s: float = 1.0,
                 dac: Dac | None = None, step_threshold_s: float | None = 1e-6, fast: bool = True):
        super().__init__(interval_s=interval_s, dac=dac, step_threshold_s=step_threshold_s, fast=fast)
        self.kp = kp
        self.ki = ki

    @classmethod
    def from_bandwidth(cls, natural_hz: float, damping: float = 1.0, *, interval_s: float = 1.0, **kw) -> PiServo:
        """Gains of a type-2 loop of natural frequency ``natural_hz`` and damping ``damping``:
        ``kp = 2 zeta w_n dt``, ``ki = (w_n dt)^2`` with ``w_n = 2 pi natural_hz``."""
        check_scalar(natural_hz, "natural_hz", min_val=0.0, include_min=False)
        check_scalar(damping, "damping", min_val=0.0, include_min=False)
        wdt = 2.0 * math.pi * natural_hz * interval_s
        return cls(2.0 * damping * wdt, wdt * wdt, interval_s=interval_s, **kw)

    @property
    def time_constant_s(self) -> float:
        """``1 / w_n = dt / sqrt(ki)`` (s)."""
        return self.interval_s / math.sqrt(self.ki)

    def _check(self) -> None:
        super()._check()
        check_scalar(self.kp, "kp", min_val=0.0, max_val=2.0, include_max=False)
        check_scalar(self.ki, "ki", min_val=0.0, include_min=False)

    def _kernel_model(self, state):
        one = np.zeros((1, 1))
        return (one, one, np.zeros(1), 1.0, 4, float(self.interval_s), 1.0, self._step_thr(),
                0.0, 1.0, 1.0, 0.0, 0, 1.0, float(self.kp), float(self.ki))

    def _initial(self, n):
        return {"integral": np.zeros(n)}

    def _control(self, state, z, valid, shift):
        dt = self.interval_s
        integral = np.where(valid, state["integral"] + self.ki * z / dt, state["integral"])
        y = -(np.where(valid, self.kp * z / dt, 0.0) + integral)
        est = np.where(valid, z, np.nan)
        return {"integral": integral}, y, est, est.copy(), valid.copy()
