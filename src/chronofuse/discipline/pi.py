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

import numba
import numpy as np
from pydantic import Field, model_validator

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.servo import Servo
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.registry import Config
from chronofuse.validation import check_scalar

__all__ = ["PiServo", "PiServoConfig", "build_pi", "sample_pi", "max_natural_hz", "SEED_KP", "SEED_KI"]

SEED_KP = 0.5
SEED_KI = 0.1


@numba.njit(SAMPLE, cache=True)
def sample_pi(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel (:data:`~chronofuse.discipline.servo_kernel.SAMPLE`); ``state = [I]``, ``params = [kp, ki, dt]``."""
    kp, ki, dt = params[0], params[1], params[2]
    if math.isnan(offset_s):
        y = -(0.0 + state[0])
        out[2] = 0.0
    else:
        state[0] = state[0] + ki * offset_s / dt
        y = -(kp * offset_s / dt + state[0])
        out[2] = 1.0
    out[0] = offset_s
    out[1] = offset_s
    return y


def max_natural_hz(damping: float = 1.0, interval_s: float = 1.0) -> float:
    """The highest natural frequency :meth:`PiServo.from_bandwidth` can design a stable loop for: with
    ``u = w_n dt``, ``kp = 2 zeta u < 2`` and ``2 kp + ki = 4 zeta u + u^2 < 4`` (the module docstring's
    conditions), so ``u < min(1 / zeta, 2 (sqrt(zeta^2 + 1) - zeta))`` (Hz; 0.1318 Hz at damping 1, 1 s)."""
    u = min(1.0 / damping, 2.0 * (math.sqrt(damping * damping + 1.0) - damping))
    return u / (2.0 * math.pi * interval_s)


class PiServoConfig(Config):
    """Settings of the PI servo; ``natural_hz`` (when given) designs ``kp``, ``ki`` from a loop bandwidth."""

    kp: float = Field(SEED_KP, ge=0.0, lt=2.0, description="proportional gain per sample (dimensionless)")
    ki: float = Field(SEED_KI, gt=0.0, description="integral gain per sample (dimensionless)")
    natural_hz: float | None = Field(None, gt=0.0, le=0.5,
                                     description="design kp, ki for this natural frequency instead (Hz)")
    damping: float = Field(1.0, gt=0.0, description="damping of the designed loop (dimensionless)")
    step_threshold_s: float | None = Field(1e-6, ge=0.0,
                                           description="jam-sync threshold after a gap; None: never step (s)")

    @model_validator(mode="after")
    def _stable(self):
        if self.natural_hz is not None and self.natural_hz >= max_natural_hz(self.damping):
            raise ValueError(f"natural_hz {self.natural_hz} Hz at damping {self.damping} designs an unstable loop "
                             f"sampled each second: it must be below {max_natural_hz(self.damping):.4g} Hz")
        if self.natural_hz is None and 2.0 * self.kp + self.ki >= 4.0:
            raise ValueError(f"kp {self.kp}, ki {self.ki}: 2 kp + ki must be below 4 for a stable loop")
        return self


def build_pi(config: PiServoConfig, context) -> PiServo:
    """The registry's builder: gains from ``natural_hz`` and ``damping`` when given, else ``kp``, ``ki``."""
    common = dict(interval_s=context.get("interval_s", 1.0), dac=context.get("dac"),
                  step_threshold_s=config.step_threshold_s)
    if config.natural_hz is not None:
        return PiServo.from_bandwidth(config.natural_hz, config.damping, **common)
    return PiServo(config.kp, config.ki, **common)


class PiServo(Servo):
    """PI servo; ``kp``, ``ki`` dimensionless per-sample gains (defaults: the GNSSDO paper's 0.5 and 0.1).

    :meth:`fit` learns nothing: the gains are the design (designing them from the noise is the designer's
    job, :meth:`from_bandwidth`)."""

    name = "pi"
    kernel = sample_pi

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
        check_scalar(natural_hz, "natural_hz", max_val=max_natural_hz(damping, interval_s), include_max=False)
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
        check_scalar(2.0 * self.kp + self.ki, "2 kp + ki", max_val=4.0, include_max=False)

    def _initial(self, n):
        return {"integral": np.zeros(n)}

    def _control(self, state, z, valid, shift, weight):
        dt = self.interval_s
        integral = np.where(valid, state["integral"] + self.ki * z / dt, state["integral"])
        y = -(np.where(valid, self.kp * z / dt, 0.0) + integral)
        est = np.where(valid, z, np.nan)
        return {"integral": integral}, y, est, est.copy(), valid.copy()

    def _kernel_initial(self, n):
        return np.zeros((n, 1))

    def _kernel_params(self):
        return np.array([float(self.kp), float(self.ki), float(self.interval_s)])
