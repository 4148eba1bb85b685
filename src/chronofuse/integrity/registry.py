"""The clock-bias detectors by name: :data:`DETECTORS`, the one registry of the family (:mod:`chronofuse.registry`).

=============== ==========================================================================================
chi-square      the high-order-difference chi-square test over a window (:class:`~.detector.HodDetector`)
single-epoch    one second difference against its standard deviation (:class:`~.baselines.SingleEpochDetector`)
cusum           two-sided CUSUM on the whitened innovations (:class:`~.baselines.CusumDetector`)
reference-clock the receiver clock against a reference clock's reading (:class:`~.baselines.ReferenceClockDetector`;
                it needs the extra input ``reference_s``, so ``chronofuse detect``, which reads one clock
                bias, refuses it)
=============== ==========================================================================================

``DETECTORS.create(name, context={"interval_s": ...}, **settings)`` builds an unfitted detector; the
sampling interval is the data's, the settings are the member's config fields (``DETECTORS.describe``).

A detector that ``chronofuse detect --detector NAME`` can run on one clock bias implements
:mod:`chronofuse.estimation.interface` with no extra input (``inputs = ()``): ``fit(clock_bias_s=None)``
(None: every parameter given), ``run(clock_bias_s) -> DetectionResult`` and ``step(clock_bias_s) ->
StepOutput`` (:mod:`.result`), and has the attributes ``interval_s``, ``window`` (differences per test,
for the record-length check and the alarm latch) and ``pfa``. When present, its learnt ``h0_``, ``hm2_``,
``sigma_rho_m_`` are reported as the noise model, ``r_`` and ``inflation_`` feed the noise-change test
after training, ``training_outliers_`` marks the epochs left out of training and ``threshold_`` is the
threshold reported. A plugin is one module and one entry point in the group ``chronofuse.detectors``.
"""

from __future__ import annotations

from pydantic import Field

from chronofuse.integrity.baselines import CusumDetector, ReferenceClockDetector, SingleEpochDetector
from chronofuse.integrity.detector import HodDetector
from chronofuse.registry import Config, Entry, Registry

__all__ = ["DETECTORS", "DEFAULT_DETECTOR", "ChiSquareConfig", "SingleEpochConfig", "CusumConfig",
           "ReferenceClockConfig"]

#: What ``chronofuse detect`` runs unless told otherwise.
DEFAULT_DETECTOR = "chi-square"

_PFA = Field(1e-3, gt=0.0, lt=1.0, description="false-alarm probability per epoch (dimensionless)")
_WINDOW = Field(20, ge=1, description="window length n (epochs)")
_H0 = Field(None, ge=0.0, description="white FM level h0 of the receiver clock; None: fitted from training (s)")
_HM2 = Field(None, ge=0.0, description="random-walk FM level h-2; None: fitted from training (1/s)")
_SIGMA_RHO = Field(None, ge=0.0, description="mean pseudorange noise; None: fitted from training (m)")


class ChiSquareConfig(Config):
    """Settings of the high-order-difference chi-square detector."""

    window: int = _WINDOW
    pfa: float = _PFA
    h0: float | None = _H0
    hm2: float | None = _HM2
    sigma_rho_m: float | None = _SIGMA_RHO
    confidence: float | None = Field(None, gt=0.0, lt=1.0, description="keep P_fa at or below nominal in this "
                                                                       "share of trainings (dimensionless)")


class SingleEpochConfig(Config):
    """Settings of the single-epoch threshold."""

    pfa: float = _PFA
    h0: float | None = _H0
    hm2: float | None = _HM2
    sigma_rho_m: float | None = _SIGMA_RHO


class CusumConfig(Config):
    """Settings of the CUSUM detector."""

    window: int = _WINDOW
    pfa: float = _PFA
    drift: float = Field(0.5, ge=0.0, description="reference value, tuned to a mean shift of 2 drift "
                                                  "(innovation standard deviations)")
    h0: float | None = _H0
    hm2: float | None = _HM2
    sigma_rho_m: float | None = _SIGMA_RHO
    calibration_steps: int = Field(400_000, ge=10_000, description="simulated epochs that calibrate the "
                                                                   "threshold (epochs)")
    calibration_seed: int = Field(20_240, ge=0, description="seed of that simulation (dimensionless)")


class ReferenceClockConfig(Config):
    """Settings of the reference-clock comparison."""

    window: int = _WINDOW
    pfa: float = _PFA
    sigma_s: float | None = Field(None, gt=0.0, description="residual standard deviation; None: learnt (s)")
    offset_s: float | None = Field(None, description="residual mean; None: learnt (s)")


DETECTORS = Registry("detectors", shared=("interval_s",))
DETECTORS.add("chi-square", Entry(HodDetector, ChiSquareConfig, "high-order-difference chi-square test"))
DETECTORS.add("single-epoch", Entry(SingleEpochDetector, SingleEpochConfig, "one second difference against "
                                                                             "its standard deviation"))
DETECTORS.add("cusum", Entry(CusumDetector, CusumConfig, "two-sided CUSUM on the whitened innovations"))
DETECTORS.add("reference-clock", Entry(ReferenceClockDetector, ReferenceClockConfig,
                                       "the clock against a reference clock's reading (input reference_s)"))
