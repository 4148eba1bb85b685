"""Physical parameters of a GNSS timing receiver: :class:`ReceiverModel`.

The model itself (what the parameters do) is in :mod:`chronofuse.models.receiver`; named environments
(open sky, urban canyon, jamming, spoofing) in :mod:`chronofuse.models.environment`. The defaults are
the ``open-sky`` calibration below.

Calibration of ``open-sky`` against the real GPS-vs-maser record
----------------------------------------------------------------
Data: ``stability/gps/gps_1pps_phase_data.txt.gz`` (241,218 s of a GPS receiver's 1PPS against a
hydrogen maser, marked "AW 2016 March" in its header, via allantools' test suite) and Stable32's
tables for it.

1. Is the sawtooth in the record? No, at the 48 MHz level it cannot be: a 48 MHz sawtooth alone is
   uniform with rms ``T / sqrt(12) = 6.0 ns`` and would give ADEV(1 s) of about
   ``sqrt(3) 6.0 ns = 10.4 ns``, while the record has 6.12 ns. Its short-term noise is also Gaussian
   (Pearson kurtosis of the second difference 2.97; an i.i.d. uniform sawtooth gives 2.4), its
   spectrum above 0.1 Hz is flat at ``2.4e-17 s^2/Hz`` with no line (a sawtooth from a steady
   oscillator offset is a line), and the variance of the first difference over 300 s windows is
   nearly constant (relative spread 0.11, against 0.08 for chi-square scatter alone). The record
   therefore behaves like a qErr-corrected 1PPS (or a receiver with a far finer pulse quantization),
   and what is compared with it is ``pps_error_s + qerr_s``. The raw ``pps_error_s`` of the model
   keeps its 48 MHz sawtooth on top, so its ADEV(1 s) is about twice the record's (tested).
2. Fit. The Allan variance of a sum of independent stationary processes with autocovariance
   ``R(n)`` is ``AVAR(n tau0) = [6 R(0) - 8 R(n) + 2 R(2n)] / (2 n^2 tau0^2)`` (second difference of
   the phase, NIST SP 1065 eq. (7)); white noise adds ``sigma^2`` to ``R(0)``, a Gauss-Markov process
   adds ``sigma^2 exp(-n tau0 / tau)``. The record shows no outliers or jumps (its largest
   ``|x_{k+1} - x_k|`` is 25 ns, 4.9 sigma of the difference: the Gaussian extreme for 2.4e5 samples)
   and no outages. Least squares on ``log(model / table)`` over Stable32's overlapping-ADEV octave
   table, tau = 1 .. 8192 s (14 points), gave:

   - white noise only + one Gauss-Markov: sigma_w 3.47 ns, 6.23 ns / 28.5 s; worst misfit 16 %;
   - white + two Gauss-Markov (kept): ``white_sigma_s = 3.33 ns``, multipath ``5.26 ns, 15.1 s``,
     slow wander ``5.32 ns, 1530 s``; worst misfit 3.4 % on the octave table; on the decade ADEV
     table the model is within 0.94..1.14 of Stable32 at tau = 1 .. 1e4 s.

   The white level agrees with the flat high-frequency spectrum (``2.4e-17 s^2/Hz`` one-sided gives
   ``sigma = 3.46 ns``) and with the lag-1 correlation of the first difference (-0.44). The open-sky
   GDOP gain raises the effective white variance by ``exp(2 * 0.08^2)``, 0.6 % in rms, inside the
   fit's rounding. The fit is of second-order statistics only; it says nothing about the sawtooth,
   which step 1 set aside. :func:`chronofuse.analysis.theory.corrected_pps_adev` is this analytic ADEV.
   ``tests/models/test_receiver.py`` redoes the fit (the preset must be its optimum to 1 %) and checks
   that simulated open-sky ``pps_error_s + qerr_s`` has ADEV within a factor 1.2 of the decade table
   at tau = 1, 10, 100, 1000, 1e4 s (measured: 0.98..1.02).
"""

from __future__ import annotations

from dataclasses import dataclass

from chronofuse.validation import check_scalar

__all__ = ["ReceiverModel"]


@dataclass(frozen=True)
class ReceiverModel:
    """Physical parameters of one GNSS timing receiver (all receivers of a run share them).

    Defaults are the ``open-sky`` fit to the GPS-vs-maser record (see the module docstring); what each
    parameter does is in :mod:`chronofuse.models.receiver`.

    Parameters
    ----------
    white_sigma_s : white timing noise of the solution at ``gdop_median`` (s), >= 0.
    tick_hz : receiver clock that quantizes the 1PPS edge (Hz), > 0; sawtooth period ``1 / tick_hz``.
    multipath_sigma_s, multipath_tau_s : Gauss-Markov multipath: rms (s) and correlation time (s).
    wander_sigma_s, wander_tau_s : slow Gauss-Markov wander (atmosphere, long-period multipath).
    outlier_prob : probability that one pulse is an outlier, in [0, 1].
    outlier_sigma_s : rms of an outlier (s).
    jump_prob : probability per second of a persistent time step, in [0, 1].
    jump_sigma_s : rms of one step (s).
    outage_rate_hz : rate of fix-loss starts (1/s); outage_mean_s: their mean length (s).
    gdop_median, gdop_log_sigma, gdop_tau_s : log-normal GDOP: median, rms of ln GDOP, time constant.
    gdop_fix_max : no fix above this GDOP.
    n_sats_median, n_sats_spread, n_sats_max : satellites used (see the module docstring).
    clock_freq_offset_max : bound of the oscillator's fractional frequency offset (uniform).
    clock_initial_bias_max_s : bound of the initial clock bias (uniform, s).
    clock_h0 : white FM level h0 of the receiver oscillator (s, i.e. 1/Hz).
    clock_hm2 : random-walk FM level ``h_-2`` (1/s, i.e. Hz).
    """

    white_sigma_s: float = 3.33e-9
    tick_hz: float = 48e6
    multipath_sigma_s: float = 5.26e-9
    multipath_tau_s: float = 15.1
    wander_sigma_s: float = 5.32e-9
    wander_tau_s: float = 1530.0
    outlier_prob: float = 0.0
    outlier_sigma_s: float = 50e-9
    jump_prob: float = 0.0
    jump_sigma_s: float = 20e-9
    outage_rate_hz: float = 0.0
    outage_mean_s: float = 30.0
    gdop_median: float = 1.5
    gdop_log_sigma: float = 0.08
    gdop_tau_s: float = 1800.0
    gdop_fix_max: float = 20.0
    n_sats_median: float = 11.0
    n_sats_spread: float = 1.0
    n_sats_max: int = 32
    clock_freq_offset_max: float = 5e-7
    clock_initial_bias_max_s: float = 1e-6
    clock_h0: float = 2e-19
    clock_hm2: float = 1e-23

    def __post_init__(self):
        for name in ("white_sigma_s", "multipath_sigma_s", "wander_sigma_s", "outlier_sigma_s",
                     "jump_sigma_s", "outage_rate_hz", "gdop_log_sigma", "n_sats_spread",
                     "clock_freq_offset_max", "clock_initial_bias_max_s", "clock_h0", "clock_hm2"):
            check_scalar(getattr(self, name), name, min_val=0.0)
        for name in ("tick_hz", "multipath_tau_s", "wander_tau_s", "outage_mean_s", "gdop_tau_s"):
            check_scalar(getattr(self, name), name, min_val=0.0, include_min=False)
        for name in ("outlier_prob", "jump_prob"):
            check_scalar(getattr(self, name), name, min_val=0.0, max_val=1.0)
        check_scalar(self.gdop_median, "gdop_median", min_val=1.0)
        check_scalar(self.gdop_fix_max, "gdop_fix_max", min_val=1.0)
        check_scalar(self.n_sats_max, "n_sats_max", min_val=4, integer=True)
        check_scalar(self.n_sats_median, "n_sats_median", min_val=4, max_val=self.n_sats_max)

