"""ITU-T wander masks for primary reference clocks: MTIE and TDEV limits, and max |TE|, with pass/fail.

Sources (limits as piecewise functions of the observation interval ``tau``; every breakpoint below
names its table):

- ITU-T G.8272/Y.1367 (11/2018), "Timing characteristics of primary reference time clocks":
  Table 1 (PRTC-A MTIE), Table 2 (PRTC-B MTIE), Table 3 (PRTC-A TDEV), Table 4 (PRTC-B TDEV);
  clause 6.1: time error of the PRTC-A within 100 ns, PRTC-B within 40 ns, of the applicable primary
  time standard (max |TE|).
- ITU-T G.811 (09/1997) with Amendment 1 (04/2016), "Timing characteristics of primary reference
  clocks": Table 1 (PRC MTIE), Table 2 (PRC TDEV). G.811 has no time-error limit.

``MASKS[clock].check(deviation)`` checks one MTIE or TDEV curve (:class:`MaskResult`, per-tau margins);
``MASKS[clock].check(x_s, rate_hz)`` checks a time-error record for MTIE, TDEV and max |TE| at once
(:class:`ClockVerdict`).

The masks start at ``tau > 0.1 s`` (all four tables); an observation interval at or below 0.1 s is not
covered and is reported as not evaluated (NaN limit, excluded from the verdict). The last segment of
each table is open-ended here (the recommendations' TDEV tables stop at 1e4 s or 1e5 s observation
intervals; beyond them the last limit is applied).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.analysis.stability import mtie, tau_grid, tdev
from chronofuse.analysis.stability.result import Deviation
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = ["MaskSegment", "Mask", "MaskResult", "ClockMasks", "ClockVerdict", "TimeErrorResult", "MASKS"]

METRICS = ("mtie", "tdev")
_REL_TOL = 1e-12


@dataclass(frozen=True)
class MaskSegment:
    """One row of a mask table: ``limit_s = offset_s + slope * tau_s`` for ``tau_lo_s < tau_s <= tau_hi_s``.

    ``tau_hi_s`` may be ``inf`` (open-ended last row). ``source`` names the recommendation's table.
    """

    tau_lo_s: float
    tau_hi_s: float
    offset_s: float
    slope: float
    source: str

    def __post_init__(self):
        check_scalar(self.tau_lo_s, "tau_lo_s", min_val=0)
        if not self.tau_hi_s > self.tau_lo_s:
            raise ValueError(f"tau_hi_s == {self.tau_hi_s}, must be > tau_lo_s == {self.tau_lo_s}")
        check_scalar(self.offset_s, "offset_s")
        check_scalar(self.slope, "slope")


@dataclass(frozen=True)
class MaskResult:
    """Outcome of checking a measured curve against a mask; arrays of shape (k,).

    ``margin_s = limit_s - value_s`` (positive: inside the mask); ``evaluated`` is false where the mask
    does not cover ``tau_s`` or the value is NaN; ``passed_each`` is true where evaluated and
    ``value_s <= limit_s``; ``passed`` is true when every evaluated point passes and at least one was
    evaluated.
    """

    mask: str
    metric: str
    tau_s: np.ndarray
    value_s: np.ndarray
    limit_s: np.ndarray
    margin_s: np.ndarray
    evaluated: np.ndarray
    passed_each: np.ndarray
    passed: bool

    @property
    def worst_margin_s(self) -> float:
        """Smallest margin over the evaluated points (negative: the worst violation); NaN if none."""
        m = self.margin_s[self.evaluated]
        return float(m.min()) if m.size else float("nan")

    def to_dict(self) -> dict:
        """JSON-ready dict (NaN -> None)."""
        return {
            "mask": self.mask,
            "metric": self.metric,
            "tau": _clean(self.tau_s),
            "value": _clean(self.value_s),
            "limit": _clean(self.limit_s),
            "margin": _clean(self.margin_s),
            "evaluated": self.evaluated.tolist(),
            "passed_each": self.passed_each.tolist(),
            "passed": self.passed,
        }


def _clean(a: np.ndarray) -> list:
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, dtype=float)]


@dataclass(frozen=True)
class Mask:
    """A wander mask: MTIE or TDEV limit (seconds) as a piecewise-linear function of ``tau_s``."""

    name: str
    metric: str
    segments: tuple[MaskSegment, ...]

    def __post_init__(self):
        check_choice(self.metric, "metric", METRICS)
        if not self.segments:
            raise ValueError(f"segments of mask {self.name!r} is empty, must hold at least one MaskSegment")
        for a, b in zip(self.segments[:-1], self.segments[1:]):
            if a.tau_hi_s != b.tau_lo_s:
                raise ValueError(
                    f"mask {self.name!r}: segment ending at {a.tau_hi_s} s is followed by one at {b.tau_lo_s} s"
                )

    @property
    def tau_min_s(self) -> float:
        """Observation intervals must exceed this to be covered."""
        return self.segments[0].tau_lo_s

    def limit_s(self, tau_s) -> np.ndarray:
        """Mask limit in seconds at each ``tau_s`` (k,); NaN where ``tau_s <= tau_min_s``."""
        tau = check_array(np.atleast_1d(np.asarray(tau_s, dtype=float)), "tau_s")
        out = np.full(tau.shape, np.nan)
        for seg in self.segments:
            inside = (tau > seg.tau_lo_s) & (tau <= seg.tau_hi_s)
            out[inside] = seg.offset_s + seg.slope * tau[inside]
        return out

    def check(self, deviation_or_values, value_s=None) -> MaskResult:
        """Check a measured curve against this mask.

        Parameters
        ----------
        deviation_or_values : Deviation or array-like of shape (k,)
            A :class:`Deviation` of this mask's metric (``"mtie"`` or ``"tdev"``), or the observation
            intervals ``tau_s`` (k,) when ``value_s`` is given.
        value_s : array-like of shape (k,), optional
            The MTIE or TDEV values in seconds, with ``tau_s`` given first.
        """
        if isinstance(deviation_or_values, Deviation):
            dev = deviation_or_values
            if dev.statistic != self.metric:
                raise ValueError(
                    f"deviation.statistic == {dev.statistic!r}, must be {self.metric!r} for mask {self.name!r}"
                )
            tau, values = np.asarray(dev.tau_s, dtype=float), np.asarray(dev.dev, dtype=float)
        else:
            if value_s is None:
                raise ValueError("value_s is None, must be given with tau_s (or pass a Deviation)")
            tau = check_array(deviation_or_values, "tau_s")
            values = check_array(value_s, "value_s", allow_nan=True)
            if values.shape != tau.shape:
                raise ValueError(f"value_s has shape {values.shape}, must match tau_s {tau.shape}")
        limit = self.limit_s(tau)
        evaluated = np.isfinite(limit) & np.isfinite(values)
        margin = limit - values
        # A value equal to the limit passes; the tolerance absorbs float rounding of the table's
        # arithmetic (0.03 ns/s * 1000 s is not exactly 30 ns in binary).
        passed_each = evaluated & (values <= limit * (1.0 + _REL_TOL))
        passed = bool(evaluated.any() and np.all(passed_each[evaluated]))
        return MaskResult(self.name, self.metric, tau, values, limit, margin, evaluated, passed_each, passed)


@dataclass(frozen=True)
class TimeErrorResult:
    """Max |TE| check: ``max_abs_te_s`` over the non-NaN samples against ``limit_s``."""

    clock: str
    max_abs_te_s: float
    limit_s: float
    margin_s: float
    passed: bool

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {
            "clock": self.clock,
            "max_abs_te": self.max_abs_te_s,
            "limit": self.limit_s,
            "margin": self.margin_s,
            "passed": self.passed,
        }


@dataclass(frozen=True)
class ClockVerdict:
    """A phase record checked against one clock class: MTIE, TDEV and (if defined) max |TE|."""

    clock: str
    mtie: MaskResult
    tdev: MaskResult
    time_error: TimeErrorResult | None
    passed: bool

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {
            "clock": self.clock,
            "mtie": self.mtie.to_dict(),
            "tdev": self.tdev.to_dict(),
            "time_error": None if self.time_error is None else self.time_error.to_dict(),
            "passed": self.passed,
        }


@dataclass(frozen=True)
class ClockMasks:
    """The limits of one clock class: MTIE and TDEV masks, and max |TE| (None if it has none)."""

    name: str
    mtie: Mask
    tdev: Mask
    max_abs_te_s: float | None
    reference: str

    def limit_s(self, metric: str, tau_s) -> np.ndarray:
        """Limit in seconds of the ``metric`` (``"mtie"`` or ``"tdev"``) mask at ``tau_s`` (k,)."""
        check_choice(metric, "metric", METRICS)
        return getattr(self, metric).limit_s(tau_s)

    def check(self, deviation_or_phase, rate_hz: float | None = None) -> MaskResult | ClockVerdict:
        """Check against this clock class.

        ``check(deviation)``: an MTIE or TDEV :class:`Deviation` against the matching mask, returns a
        :class:`MaskResult`. ``check(x_s, rate_hz)``: a time-error (phase) record ``x_s`` (N,) in seconds
        (NaN: missing) at ``rate_hz``: its MTIE and TDEV on the octave grid and its max |TE|, returns a
        :class:`ClockVerdict` that passes when all three pass.
        """
        if isinstance(deviation_or_phase, Deviation):
            check_choice(deviation_or_phase.statistic, "deviation.statistic", METRICS)
            mask = self.mtie if deviation_or_phase.statistic == "mtie" else self.tdev
            return mask.check(deviation_or_phase)
        if rate_hz is None:
            raise ValueError("rate_hz is None, must be given with a phase record x_s (or pass a Deviation)")
        x = check_array(deviation_or_phase, "x_s", allow_nan=True)
        res_mtie = self.mtie.check(mtie(x, rate_hz, tau_grid("octave", x.size, rate_hz, "mtie")))
        res_tdev = self.tdev.check(tdev(x, rate_hz, tau_grid("octave", x.size, rate_hz, "tdev")))
        te = self.check_time_error(x) if self.max_abs_te_s is not None else None
        passed = res_mtie.passed and res_tdev.passed and (te is None or te.passed)
        return ClockVerdict(self.name, res_mtie, res_tdev, te, bool(passed))

    def check_time_error(self, te_s) -> TimeErrorResult:
        """Check a time-error record ``te_s`` (N,) in seconds (NaN: missing) against max |TE|."""
        if self.max_abs_te_s is None:
            raise ValueError(f"clock == {self.name!r} has no max |TE| limit ({self.reference})")
        te = check_array(te_s, "te_s", allow_nan=True)
        if not np.isfinite(te).any():
            raise InputError("te_s has no valid sample")
        peak = float(np.nanmax(np.abs(te)))
        margin = self.max_abs_te_s - peak
        return TimeErrorResult(self.name, peak, self.max_abs_te_s, margin, bool(peak <= self.max_abs_te_s))


_US = 1e-6
_NS = 1e-9
_INF = float("inf")

# G.8272 Table 1 (PRTC-A MTIE): 0.275e-3 tau + 0.025 us for 0.1 < tau <= 273 s; 0.100 us for tau > 273 s.
_PRTC_A_MTIE = Mask(
    "prtc-a",
    "mtie",
    (
        MaskSegment(0.1, 273.0, 0.025 * _US, 0.275e-3 * _US, "ITU-T G.8272 Table 1"),
        MaskSegment(273.0, _INF, 0.100 * _US, 0.0, "ITU-T G.8272 Table 1"),
    ),
)
# G.8272 Table 2 (PRTC-B MTIE): 0.275e-3 tau + 0.025 us for 0.1 < tau <= 54.5 s; 0.040 us for tau > 54.5 s.
_PRTC_B_MTIE = Mask(
    "prtc-b",
    "mtie",
    (
        MaskSegment(0.1, 54.5, 0.025 * _US, 0.275e-3 * _US, "ITU-T G.8272 Table 2"),
        MaskSegment(54.5, _INF, 0.040 * _US, 0.0, "ITU-T G.8272 Table 2"),
    ),
)
# G.8272 Table 3 (PRTC-A TDEV): 3 ns for 0.1 < tau <= 100 s; 0.03 tau ns for 100 < tau <= 1000 s;
# 30 ns for 1000 < tau <= 10000 s.
_PRTC_A_TDEV = Mask(
    "prtc-a",
    "tdev",
    (
        MaskSegment(0.1, 100.0, 3.0 * _NS, 0.0, "ITU-T G.8272 Table 3"),
        MaskSegment(100.0, 1000.0, 0.0, 0.03 * _NS, "ITU-T G.8272 Table 3"),
        MaskSegment(1000.0, _INF, 30.0 * _NS, 0.0, "ITU-T G.8272 Table 3"),
    ),
)
# G.8272 Table 4 (PRTC-B TDEV): 1 ns for 0.1 < tau <= 100 s; 0.01 tau ns for 100 < tau <= 500 s;
# 5 ns for tau > 500 s.
_PRTC_B_TDEV = Mask(
    "prtc-b",
    "tdev",
    (
        MaskSegment(0.1, 100.0, 1.0 * _NS, 0.0, "ITU-T G.8272 Table 4"),
        MaskSegment(100.0, 500.0, 0.0, 0.01 * _NS, "ITU-T G.8272 Table 4"),
        MaskSegment(500.0, _INF, 5.0 * _NS, 0.0, "ITU-T G.8272 Table 4"),
    ),
)
# G.811 Table 1 (PRC MTIE): 0.275e-3 tau + 0.025 us for 0.1 < tau <= 1000 s; 1e-5 tau + 0.29 us for tau > 1000 s.
_G811_MTIE = Mask(
    "g811",
    "mtie",
    (
        MaskSegment(0.1, 1000.0, 0.025 * _US, 0.275e-3 * _US, "ITU-T G.811 Table 1"),
        MaskSegment(1000.0, _INF, 0.29 * _US, 1e-5 * _US, "ITU-T G.811 Table 1"),
    ),
)
# G.811 Table 2 (PRC TDEV): 3 ns for 0.1 < tau <= 100 s; 0.03 tau ns for 100 < tau <= 1000 s;
# 30 ns for 1000 < tau <= 10000 s.
_G811_TDEV = Mask(
    "g811",
    "tdev",
    (
        MaskSegment(0.1, 100.0, 3.0 * _NS, 0.0, "ITU-T G.811 Table 2"),
        MaskSegment(100.0, 1000.0, 0.0, 0.03 * _NS, "ITU-T G.811 Table 2"),
        MaskSegment(1000.0, _INF, 30.0 * _NS, 0.0, "ITU-T G.811 Table 2"),
    ),
)

MASKS: dict[str, ClockMasks] = {
    "prtc-a": ClockMasks("prtc-a", _PRTC_A_MTIE, _PRTC_A_TDEV, 100.0 * _NS, "ITU-T G.8272 (11/2018) clause 6.1"),
    "prtc-b": ClockMasks("prtc-b", _PRTC_B_MTIE, _PRTC_B_TDEV, 40.0 * _NS, "ITU-T G.8272 (11/2018) clause 6.1"),
    "g811": ClockMasks("g811", _G811_MTIE, _G811_TDEV, None, "ITU-T G.811 (1997) Amd. 1 (2016)"),
}
