"""ITU-T wander masks and time-error limits, with pass/fail verdicts that keep cTE and dTE apart.

The limits are data (:mod:`chronofuse.analysis.mask_tables`, every row naming the recommendation's
table it transcribes); this module builds :data:`MASKS` from them and checks records against them:

- ``MASKS[clock].check(deviation)`` checks one MTIE or TDEV curve (:class:`MaskResult`, per-tau margins);
- ``MASKS[clock].check(x_s, rate_hz, offset="measured")`` checks a time-error record against everything
  the clock class specifies (:class:`ClockVerdict`): MTIE and TDEV of the dynamic time error (after the
  0.1 Hz low-pass where the recommendation says so), max |TE|, cTE, max |TE_L| and dTE_H peak to peak.
  ``offset="arbitrary"`` says the record's constant offset is not a time error (a counter started
  anywhere against a reference that is not the time scale, like the Cs 5071A against an H-maser): the
  limits that see the constant (max |TE|, cTE, max |TE_L|) are then not evaluated, and the verdict says
  so. With ``"measured"`` they are, and the verdict splits max |TE| into cTE and dTE
  (:func:`chronofuse.analysis.time_error.split_time_error`) so a failure from the offset is told apart
  from one from wander.

A mask row holds for ``tau_lo < tau <= tau_hi`` unless its table writes the ends otherwise; an
observation interval no row covers is not evaluated (NaN limit) and is left out of the verdict. A value
equal to the limit passes (with a 1e-12 relative tolerance for float rounding).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from chronofuse.analysis import time_error as te_mod
from chronofuse.analysis.mask_results import REL_TOL as _REL_TOL
from chronofuse.analysis.mask_results import ClockVerdict, LimitResult, MaskResult, TimeErrorResult
from chronofuse.analysis.mask_results import limit_result as _limit
from chronofuse.analysis.mask_tables import NOT_TRANSCRIBED, TABLES
from chronofuse.analysis.stability import mtie, tau_grid, tdev
from chronofuse.analysis.stability.engine import uncovered_samples
from chronofuse.analysis.stability.result import Deviation
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = ["MaskSegment", "Mask", "MaskResult", "ClockMasks", "ClockVerdict", "TimeErrorResult", "LimitResult",
           "MASKS", "OFFSETS", "NOT_TRANSCRIBED"]

METRICS = ("mtie", "tdev")
#: How a record's constant offset is to be read: as time error, or as an arbitrary constant.
OFFSETS = ("measured", "arbitrary")
_NS = 1e-9
# The tables' "m" (the measurement's sample interval) when none is known: 1 s, the 1 PPS case of their notes.
_DEFAULT_INTERVAL_S = 1.0


@dataclass(frozen=True)
class MaskSegment:
    """One row of a mask table: ``limit_s = offset_s + slope * tau_s + sum(c * tau_s**p for c, p in terms)``.

    Holds for ``tau_lo_s < tau_s <= tau_hi_s`` (``lo_closed``/``hi_closed`` change the ends as the table
    writes them). ``tau_hi_s`` may be ``inf`` (open-ended last row). ``lo_is_interval``: the lower end is the
    table's ``m``, the record's sample interval (``tau_lo_s`` is then its value when none is known).
    ``source`` names the recommendation's table.
    """

    tau_lo_s: float
    tau_hi_s: float
    offset_s: float = 0.0
    slope: float = 0.0
    source: str = ""
    terms: tuple[tuple[float, float], ...] = ()
    lo_closed: bool = False
    hi_closed: bool = True
    lo_is_interval: bool = False

    def __post_init__(self):
        check_scalar(self.tau_lo_s, "tau_lo_s", min_val=0)
        if not self.tau_hi_s > self.tau_lo_s:
            raise ValueError(f"tau_hi_s == {self.tau_hi_s}, must be > tau_lo_s == {self.tau_lo_s}")
        check_scalar(self.offset_s, "offset_s")
        check_scalar(self.slope, "slope")
        for c, p in self.terms:
            check_scalar(c, "terms coefficient")
            check_scalar(p, "terms power")

    def covers(self, tau: np.ndarray, interval_s: float | None = None) -> np.ndarray:
        """Which ``tau`` (k,) this row holds for."""
        lo = (interval_s if interval_s is not None else self.tau_lo_s) if self.lo_is_interval else self.tau_lo_s
        above = tau >= lo if self.lo_closed else tau > lo
        below = tau <= self.tau_hi_s if self.hi_closed else tau < self.tau_hi_s
        return above & below

    def value_s(self, tau: np.ndarray) -> np.ndarray:
        """The row's formula at ``tau`` (k,), seconds."""
        out = self.offset_s + self.slope * tau
        for c, p in self.terms:
            out = out + c * tau**p
        return out


@dataclass(frozen=True)
class Mask:
    """A wander mask: MTIE or TDEV limit (seconds) as a piecewise function of ``tau_s``."""

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
            if a.hi_closed and b.lo_closed:
                raise ValueError(f"mask {self.name!r}: two segments both hold tau = {a.tau_hi_s} s")

    @property
    def tau_min_s(self) -> float:
        """Observation intervals must exceed this to be covered (the sample interval for rows from ``m``)."""
        return self.segments[0].tau_lo_s

    def limit_s(self, tau_s, interval_s: float | None = None) -> np.ndarray:
        """Mask limit in seconds at each ``tau_s`` (k,); NaN where no row covers it. ``interval_s``: the
        record's sample interval, the lower end of rows written from the tables' ``m``."""
        tau = check_array(np.atleast_1d(np.asarray(tau_s, dtype=float)), "tau_s")
        out = np.full(tau.shape, np.nan)
        for seg in self.segments:
            inside = seg.covers(tau, interval_s)
            out[inside] = seg.value_s(tau[inside])
        return out

    def table_end_s(self, interval_s: float | None = None) -> float:
        """Where the table's rows end: the last row's upper end, or the start of an open-ended last row
        (a record must reach it for the table to be covered)."""
        last = self.segments[-1]
        if np.isfinite(last.tau_hi_s):
            return float(last.tau_hi_s)
        lo = interval_s if (last.lo_is_interval and interval_s is not None) else last.tau_lo_s
        return float(lo)

    def evaluation_factors(self, rate_hz: float, max_m: int, tau_s=None) -> np.ndarray:
        """Averaging factors (k,) to evaluate this mask at, on a record at ``rate_hz`` whose statistic
        reaches ``max_m``: the octave factors, those of the asked ``tau_s`` (seconds; the ones that are
        whole multiples of the sample interval and within reach), each row's first and last covered factor
        (its breakpoints and ends, the last clamped to ``max_m``) and ``max_m`` itself, so that a violation
        at a table's end is never missed. Only factors some row covers are kept."""
        interval = 1.0 / rate_hz
        if max_m < 1:
            return np.zeros(0, dtype=np.int64)
        m = set(int(v) for v in 2 ** np.arange(int(np.floor(np.log2(max_m))) + 1))
        m.add(int(max_m))
        if tau_s is not None:
            asked = np.atleast_1d(np.asarray(tau_s, dtype=float))
            asked = asked[np.isfinite(asked) & (asked > 0)]
            factors = np.rint(asked * rate_hz)
            whole = np.abs(factors * interval - asked) <= 1e-9 * asked
            m.update(int(f) for f in factors[whole] if 1 <= f <= max_m)
        for seg in self.segments:
            lo = interval if seg.lo_is_interval else seg.tau_lo_s
            first = max(int(np.ceil(lo * rate_hz * (1 - _REL_TOL))), 1)
            for k in (first, first + 1):
                if k <= max_m and seg.covers(np.array([k * interval]), interval)[0]:
                    m.add(k)
                    break
            if np.isfinite(seg.tau_hi_s):
                last = min(int(np.floor(seg.tau_hi_s * rate_hz * (1 + _REL_TOL))), int(max_m))
                for k in (last, last - 1):
                    if k >= 1 and seg.covers(np.array([k * interval]), interval)[0]:
                        m.add(k)
                        break
        out = np.array(sorted(m), dtype=np.int64)
        return out[np.isfinite(self.limit_s(out * interval, interval))]

    def check(self, deviation_or_values, value_s=None, *, interval_s: float | None = None,
              reach_s: float | None = None) -> MaskResult:
        """Check a measured curve against this mask.

        Parameters
        ----------
        deviation_or_values : Deviation or array-like of shape (k,)
            A :class:`Deviation` of this mask's metric (``"mtie"`` or ``"tdev"``), or the observation
            intervals ``tau_s`` (k,) when ``value_s`` is given.
        value_s : array-like of shape (k,), optional
            The MTIE or TDEV values in seconds, with ``tau_s`` given first.
        interval_s : float, optional
            The record's sample interval (the tables' ``m``).
        reach_s : float, optional
            The largest observation interval the record gives (the statistic's largest factor times the
            sample interval). A record whose reach stops before the table's end (:meth:`table_end_s`)
            gives the verdict ``"incomplete"``, not a pass. Default: the largest ``tau_s`` with a value.
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
        limit = self.limit_s(tau, interval_s)
        evaluated = np.isfinite(limit) & np.isfinite(values)
        margin = limit - values
        # A value equal to the limit passes; the tolerance absorbs float rounding of the table's
        # arithmetic (0.03 ns/s * 1000 s is not exactly 30 ns in binary).
        passed_each = evaluated & (values <= limit * (1.0 + _REL_TOL))
        passed = bool(evaluated.any() and np.all(passed_each[evaluated]))
        sources = tuple(dict.fromkeys(seg.source for seg in self.segments))
        if reach_s is None:
            finite = tau[np.isfinite(values)]
            reach_s = float(finite.max()) if finite.size else 0.0
        if interval_s is None:
            interval_s = 0.0
        return MaskResult(self.name, self.metric, tau, values, limit, margin, evaluated, passed_each, passed, sources,
                          float(reach_s), self.table_end_s(interval_s or None), float(interval_s))


@dataclass(frozen=True)
class ClockMasks:
    """What one recommendation specifies for one clock class or reference point.

    ``mtie``/``tdev``: the wander masks (None where none is specified); ``max_abs_te_s``: max |TE|
    unfiltered (None if none); ``cte_s``: the |cTE| limit; ``max_abs_te_l_s``: max |TE_L| after the 0.1 Hz
    low-pass; ``dte_h_pp_s``: dTE_H peak to peak after the 0.1 Hz high-pass; ``filtered``: the MTIE/TDEV
    masks are of dTE_L. ``sources`` names the table of each scalar limit.
    """

    name: str
    mtie: Mask | None
    tdev: Mask | None
    max_abs_te_s: float | None
    reference: str
    title: str = ""
    filtered: bool = False
    cte_s: float | None = None
    max_abs_te_l_s: float | None = None
    dte_h_pp_s: float | None = None
    sources: dict = field(default_factory=dict)
    not_specified: str = ""

    def mask(self, metric: str) -> Mask:
        """The ``metric`` (``"mtie"`` or ``"tdev"``) mask; a ValueError naming the clock if it has none."""
        check_choice(metric, "metric", METRICS)
        found = getattr(self, metric)
        if found is None:
            raise ValueError(f"clock == {self.name!r} has no {metric.upper()} mask ({self.not_specified or self.reference})")
        return found

    def limit_s(self, metric: str, tau_s, interval_s: float | None = None) -> np.ndarray:
        """Limit in seconds of the ``metric`` mask at ``tau_s`` (k,); NaN where uncovered or absent."""
        check_choice(metric, "metric", METRICS)
        found = getattr(self, metric)
        if found is None:
            return np.full(np.atleast_1d(np.asarray(tau_s, dtype=float)).shape, np.nan)
        return found.limit_s(tau_s, interval_s)

    def check(self, deviation_or_phase, rate_hz: float | None = None, *, offset: str = "measured",
              tau_s=None) -> MaskResult | ClockVerdict:
        """Check against this clock class.

        ``check(deviation)``: an MTIE or TDEV :class:`Deviation` against the matching mask, returns a
        :class:`MaskResult`. ``check(x_s, rate_hz, offset=..., tau_s=...)``: a time-error (phase) record
        ``x_s`` (N,) in seconds (NaN: missing) at ``rate_hz``, against every limit of the class, returns a
        :class:`ClockVerdict` (module docstring). MTIE and TDEV are computed at the octave observation
        intervals, the asked ``tau_s`` (seconds, optional) and every row's breakpoints and ends that the
        record reaches (:meth:`Mask.evaluation_factors`), so a violation at a table's end is never missed;
        what the record does not reach (a tau range, the cTE averaging window) is named in the verdict's
        ``not_covered``, and the verdict is then ``"incomplete"``, not a pass.
        """
        if isinstance(deviation_or_phase, Deviation):
            check_choice(deviation_or_phase.statistic, "deviation.statistic", METRICS)
            return self.mask(deviation_or_phase.statistic).check(deviation_or_phase)
        if rate_hz is None:
            raise ValueError("rate_hz is None, must be given with a phase record x_s (or pass a Deviation)")
        check_choice(offset, "offset", OFFSETS)
        x = check_array(deviation_or_phase, "x_s", allow_nan=True)
        check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
        interval = 1.0 / rate_hz
        split = te_mod.split_time_error(x, rate_hz)
        notes: list[str] = []
        uncovered: list[str] = []
        limits: list[LimitResult] = []
        dte = x - split.cte_s
        filter_ok = interval <= te_mod.MAX_FILTER_INTERVAL_S
        if self.filtered and not filter_ok:
            uncovered.append(f"the 0.1 Hz measurement filter needs samples {te_mod.MAX_FILTER_INTERVAL_S:g} s apart "
                             f"or closer (these are {interval:g} s): dTE_L MTIE/TDEV, max |TE_L| and dTE_H")
        te_l = te_mod.low_pass(x, rate_hz) if self.filtered and filter_ok else None
        wander = (te_l - split.cte_s) if te_l is not None else dte
        res_mtie = res_tdev = None
        label = " of dTE_L" if self.filtered else ""
        if not self.filtered or filter_ok:
            if self.mtie is not None:
                res_mtie = self._check_metric(self.mtie, mtie, wander, rate_hz, tau_s)
            if self.tdev is not None:
                res_tdev = self._check_metric(self.tdev, tdev, wander, rate_hz, tau_s)
                res_tdev = _blind_tdev(res_tdev, wander, rate_hz, notes)
            for res in (res_mtie, res_tdev):
                if res is not None and (~np.isfinite(res.value_s) & np.isfinite(res.limit_s)).any():
                    holes = res.tau_s[~np.isfinite(res.value_s) & np.isfinite(res.limit_s)]
                    uncovered.append(f"{res.metric.upper()}{label} at tau {', '.join(f'{t:g}' for t in holes)} s: no "
                                     "term the gap rule keeps")
                if res is not None and res.not_covered_above_s is not None:
                    uncovered.append(f"tau > {res.not_covered_above_s:g} s for {res.metric.upper()}{label} (the table "
                                     f"goes to {res.required_s:g} s; the record reaches {res.not_covered_above_s:g} s)")
            if te_l is not None and self.dte_h_pp_s is not None:
                high = x - te_l
                limits.append(_limit("dte_h_pp", float(np.nanmax(high) - np.nanmin(high)), self.dte_h_pp_s,
                                     self.sources.get("dte_h_pp", self.reference)))
        absolute = offset == "measured"
        res_te = None
        if self.max_abs_te_s is not None:
            if absolute:
                res_te = self.check_time_error(x)
            else:
                notes.append("max |TE|: the record's constant offset is arbitrary (offset='arbitrary')")
        if self.cte_s is not None:
            span_s = x.size * interval
            if not absolute:
                notes.append("cTE: the record's constant offset is arbitrary")
            elif span_s < te_mod.CTE_WINDOW_S * (1.0 - _REL_TOL):
                uncovered.append(f"|cTE| is averaged over {te_mod.CTE_WINDOW_S:g} s and the record spans "
                                 f"{span_s:g} s")
            else:
                limits.insert(0, _limit("cte", abs(split.cte_worst_s), self.cte_s, self.sources.get("cte", self.reference)))
        if self.max_abs_te_l_s is not None and te_l is not None:
            if absolute:
                limits.append(_limit("max_abs_te_l", float(np.nanmax(np.abs(te_l))), self.max_abs_te_l_s,
                                     self.sources.get("max_abs_te_l", self.reference)))
            else:
                notes.append("max |TE_L|: the record's constant offset is arbitrary")
        return ClockVerdict(self.name, res_mtie, res_tdev, res_te, False, split, tuple(limits), tuple(notes),
                            offset, self.filtered, tuple(uncovered))

    @staticmethod
    def _check_metric(mask: Mask, statistic, wander: np.ndarray, rate_hz: float, tau_s) -> MaskResult:
        """``mask`` checked on ``statistic`` (:func:`mtie` or :func:`tdev`) of ``wander`` at the factors of
        :meth:`Mask.evaluation_factors`, with the record's reach."""
        from chronofuse.analysis.stability import STATISTICS

        interval = 1.0 / rate_hz
        max_m = int(STATISTICS[mask.metric].max_m(wander.size))
        factors = mask.evaluation_factors(rate_hz, max_m, tau_s)
        reach = max_m * interval if max_m >= 1 else 0.0
        if factors.size == 0:  # no tau the record gives is in the table
            empty = np.zeros(0)
            return mask.check(empty, empty, interval_s=interval, reach_s=reach)
        values = np.asarray(statistic(wander, rate_hz, factors * interval).dev, dtype=float)
        if mask.metric == "mtie":
            factors, values = _refine_mtie(mask, wander, rate_hz, factors, values)
        return mask.check(factors * interval, values, interval_s=interval, reach_s=reach)

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


#: Factors of one stretch between two evaluated ones whose fate the bounds already settle as a failure,
#: beyond which only the worst of them (the smallest limit) is evaluated: the verdict is a failure anyway.
_REFINE_SETTLED = 64
#: Undecided factors of one stretch evaluated directly; more are halved first.
_REFINE_DIRECT = 32


def _refine_mtie(mask: Mask, wander: np.ndarray, rate_hz: float, factors: np.ndarray,
                 values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``factors``/``values`` (MTIE at them) with every factor between two evaluated ones added where the mask
    could be crossed there.

    MTIE never decreases with tau (a window of ``m + 1`` samples lies inside one of ``m + 2``, missing samples
    ignored inside a window), so between evaluated factors ``a < b``, ``MTIE(a) <= MTIE(m) <= MTIE(b)``: a factor
    ``m`` whose limit is at least ``MTIE(b)`` passes, one whose limit is below ``MTIE(a)`` fails, and only
    the others are undecided. Undecided factors are evaluated (directly when few, else the stretch is halved at
    the middle one and each half bounded again), so a crossing of the mask between the octave and breakpoint
    factors is never missed and every failing factor is reported; of more than :data:`_REFINE_SETTLED` settled
    failures in one stretch only the worst is evaluated."""
    from chronofuse.analysis.stability import mtie

    interval = 1.0 / rate_hz
    known = {int(f): float(v) for f, v in zip(factors.tolist(), values.tolist())}
    finite = [f for f in sorted(known) if np.isfinite(known[f])]
    stretches = [(a, b) for a, b in zip(finite[:-1], finite[1:]) if b - a > 1]
    while stretches:
        ask: set[int] = set()
        halves: list[tuple[int, int, int]] = []
        for a, b in stretches:
            inner = np.arange(a + 1, b, dtype=np.int64)
            limit = mask.limit_s(inner * interval, interval) * (1.0 + _REL_TOL)
            covered = np.isfinite(limit)
            undecided = inner[covered & (known[b] > limit) & (known[a] <= limit)]
            settled = covered & (known[a] > limit)
            if settled.sum() > _REFINE_SETTLED:
                ask.add(int(inner[settled][np.argmin(limit[settled])]))
            else:
                ask.update(int(m) for m in inner[settled])
            if undecided.size <= _REFINE_DIRECT:
                ask.update(int(m) for m in undecided)
            else:
                mid = int(undecided[undecided.size // 2])
                ask.add(mid)
                halves.append((a, mid, b))
        ask -= set(known)
        if ask:
            m = np.array(sorted(ask), dtype=np.int64)
            known.update(zip(m.tolist(), np.asarray(mtie(wander, rate_hz, m * interval).dev, dtype=float).tolist()))
        stretches = [(lo, hi) for a, mid, b in halves for lo, hi in ((a, mid), (mid, b))
                     if hi - lo > 1 and np.isfinite(known[lo]) and np.isfinite(known[hi])]
    order = np.array(sorted(known), dtype=np.int64)
    return order, np.array([known[int(f)] for f in order])


def _blind_tdev(res: MaskResult, wander: np.ndarray, rate_hz: float, notes: list[str]) -> MaskResult:
    """``res`` with the TDEV taus left unevaluated where no term the gap rule keeps sees the record's largest
    |dTE|: between two silences closer than a term's 3 tau, a time-error burst is in no term, and TDEV
    there is that of the rest of the record (a pass that says nothing of the burst). Only passing taus are left
    out: the burst could only raise TDEV, so a tau whose rest of the record already exceeds the limit is a
    valid failure and stays one. ``notes`` gets why."""
    if not np.isnan(wander).any():
        return res
    magnitude = np.abs(wander)
    blind, where, peak, count = [], 0, 0.0, 0
    for j in np.flatnonzero(res.evaluated & res.passed_each):
        m = int(round(res.tau_s[j] * rate_hz))
        unseen = uncovered_samples("tdev", wander, m)
        if unseen.any() and np.nanmax(magnitude[unseen]) > np.nanmax(np.where(unseen, np.nan, magnitude), initial=0.0):
            blind.append(j)
            where = int(np.nanargmax(np.where(unseen, magnitude, np.nan)))
            peak, count = float(magnitude[where]), int(unseen.sum())
    if not blind:
        return res
    evaluated = res.evaluated.copy()
    evaluated[blind] = False
    passed_each = res.passed_each & evaluated
    taus = ", ".join(f"{t:g}" for t in res.tau_s[blind])
    notes.append(f"TDEV at tau {taus} s: no term the gap rule keeps sees the record's largest |dTE| "
                 f"({peak / _NS:.4g} ns at sample {where}; {count} samples unseen at tau {res.tau_s[blind[-1]]:g} s), "
                 f"between missing samples closer than 3 tau: TDEV there describes the rest of the record")
    return replace(res, evaluated=evaluated, passed_each=passed_each, passed=False)


_ENDS = {"(]": (False, True), "[]": (True, True), "()": (False, False), "[)": (True, False)}


def _segment(row: tuple) -> MaskSegment:
    lo, hi, limit, source = row[:4]
    lo_closed, hi_closed = _ENDS[row[4] if len(row) > 4 else "(]"]
    interval = lo == "m"
    terms = tuple((c * _NS, p) for c, p in limit)
    return MaskSegment(_DEFAULT_INTERVAL_S if interval else float(lo), float(hi), 0.0, 0.0, source, terms,
                       lo_closed, hi_closed, interval)


def _scalar(entry: dict, key: str) -> tuple[float | None, str | None]:
    if key not in entry:
        return None, None
    value_ns, source = entry[key]
    return value_ns * _NS, source


def _build(name: str, entry: dict) -> ClockMasks:
    masks = {metric: (Mask(name, metric, tuple(_segment(r) for r in entry[metric])) if metric in entry else None)
             for metric in METRICS}
    te, _ = _scalar(entry, "max_abs_te_ns")
    cte, cte_src = _scalar(entry, "cte_ns")
    te_l, te_l_src = _scalar(entry, "max_abs_te_l_ns")
    dte_h, dte_h_src = _scalar(entry, "dte_h_pp_ns")
    sources = {k: v for k, v in (("cte", cte_src), ("max_abs_te_l", te_l_src), ("dte_h_pp", dte_h_src)) if v}
    return ClockMasks(name, masks["mtie"], masks["tdev"], te, entry["reference"], entry.get("title", name),
                      bool(entry.get("filtered", False)), cte, te_l, dte_h, sources, entry.get("not_specified", ""))


#: Every clock class and network limit, by name (the CLI's ``--mask`` choices).
MASKS: dict[str, ClockMasks] = {name: _build(name, entry) for name, entry in TABLES.items()}
