"""What a mask check returns: per-tau results, scalar limits, and the verdict on a clock class.

The result types of :mod:`chronofuse.analysis.masks` (which re-exports them), apart so that the checks
and the tables stay readable. Every result has ``to_dict()`` (JSON-ready, NaN as None).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.analysis import time_error as te_mod

__all__ = ["MaskResult", "TimeErrorResult", "LimitResult", "ClockVerdict", "limit_result", "REL_TOL", "VERDICTS",
           "verdict_word"]

#: A value equal to a limit passes; this relative tolerance absorbs float rounding of the tables' arithmetic.
REL_TOL = 1e-12
#: The verdicts a check gives: every part evaluated passed and the record covers all the limits ask for;
#: a part failed; nothing failed but part of what the limits ask for is not covered by the record (a
#: tau range beyond its reach, the cTE averaging window longer than the record, a filter it cannot
#: take); nothing could be evaluated at all.
VERDICTS = ("pass", "fail", "incomplete", "not evaluated")


def verdict_word(status: str) -> str:
    """The verdict as printed: ``PASS``, ``FAIL``, ``INCOMPLETE``, ``NOT EVALUATED``."""
    return status.upper()


@dataclass(frozen=True)
class MaskResult:
    """Outcome of checking a measured curve against a mask; arrays of shape (k,).

    ``margin_s = limit_s - value_s`` (positive: inside the mask); ``evaluated`` is false where the mask
    does not cover ``tau_s`` or the value is NaN; ``passed_each`` is true where evaluated and
    ``value_s <= limit_s``; ``reach_s`` is the largest observation interval the record gives and
    ``required_s`` the end of the table's rows (the start of an open-ended last row), ``interval_s`` the
    sample interval; ``passed`` is true when every evaluated point passes, at least one was evaluated and
    the record reaches the table's end (``status == "pass"``).
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
    sources: tuple[str, ...] = ()
    reach_s: float = float("inf")
    required_s: float = 0.0
    interval_s: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "passed", self.status == "pass")

    @property
    def not_covered_above_s(self) -> float | None:
        """The largest observation interval the record gives (its reach) when the mask's rows go beyond it,
        so that part of the table could not be evaluated; None when the record reaches the table's end."""
        if self.interval_s > 0:  # covered when the next observation interval beyond the reach is past the end
            if self.reach_s + self.interval_s > self.required_s * (1.0 + REL_TOL):
                return None
        elif self.reach_s >= self.required_s * (1.0 - REL_TOL):
            return None
        return float(self.reach_s)

    @property
    def status(self) -> str:
        """``"fail"`` (an evaluated point over its limit), ``"not evaluated"`` (no point evaluated),
        ``"incomplete"`` (every evaluated point passes, but the record does not reach the table's end or a
        tau the table covers has no value or was left out) or ``"pass"``."""
        if (self.evaluated & ~self.passed_each).any():
            return "fail"
        if not self.evaluated.any():
            return "not evaluated"
        holes = np.isfinite(self.limit_s) & ~self.evaluated  # a tau the table covers, left unevaluated
        return "incomplete" if self.not_covered_above_s is not None or holes.any() else "pass"

    @property
    def worst_margin_s(self) -> float:
        """Smallest margin over the evaluated points (negative: the worst violation); NaN if none."""
        m = self.margin_s[self.evaluated]
        return float(m.min()) if m.size else float("nan")

    @property
    def failing_tau_s(self) -> np.ndarray:
        """Every evaluated observation interval whose value exceeds the limit (j,)."""
        return self.tau_s[self.evaluated & ~self.passed_each]

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
            "failing_tau": _clean(self.failing_tau_s),
            "sources": list(self.sources),
            "status": self.status,
            "reach": None if not np.isfinite(self.reach_s) else float(self.reach_s),
            "table_end": float(self.required_s),
            "not_covered_above": self.not_covered_above_s,
        }


def _clean(a: np.ndarray) -> list:
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, dtype=float)]


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
class LimitResult:
    """One scalar limit checked: ``quantity`` (``"cte"``, ``"max_abs_te_l"``, ``"dte_h_pp"``), its value and
    limit in seconds, the margin ``limit - value``, and the table it comes from."""

    quantity: str
    value_s: float
    limit_s: float
    margin_s: float
    passed: bool
    source: str

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {"quantity": self.quantity, "value": self.value_s, "limit": self.limit_s, "margin": self.margin_s,
                "passed": self.passed, "source": self.source}


def limit_result(quantity: str, value: float, limit: float, source: str) -> LimitResult:
    return LimitResult(quantity, float(value), float(limit), float(limit - value),
                       bool(value <= limit * (1.0 + REL_TOL)), source)


@dataclass(frozen=True)
class ClockVerdict:
    """A time-error record checked against one clock class or network limit.

    ``mtie`` and ``tdev`` (None where the recommendation has no such mask, or when not evaluated) are of the
    dynamic time error (dTE_L where ``filtered``); ``time_error`` is max |TE| (None when not specified or
    not evaluated); ``limits`` the scalar limits checked (cTE, max |TE_L|, dTE_H); ``split`` the record's
    cTE/dTE split; ``not_evaluated`` says what was left out and why (``not_covered``: the parts the record
    does not cover, which make the verdict ``"incomplete"``). ``status`` is one of :data:`VERDICTS`:
    ``"fail"`` when an evaluated part failed, ``"not evaluated"`` when no part was evaluated,
    ``"incomplete"`` when nothing failed but the record leaves part of what the class asks for
    uncovered, else ``"pass"``; ``passed`` is true only for ``"pass"``.
    """

    clock: str
    mtie: MaskResult | None
    tdev: MaskResult | None
    time_error: TimeErrorResult | None
    passed: bool
    split: te_mod.TimeErrorSplit | None = None
    limits: tuple[LimitResult, ...] = ()
    not_evaluated: tuple[str, ...] = ()
    offset: str = "measured"
    filtered: bool = False
    not_covered: tuple[str, ...] = ()
    status: str = ""

    def __post_init__(self):
        if not self.status:  # derived from the parts when not given
            object.__setattr__(self, "status", _status(self))
        object.__setattr__(self, "passed", self.status == "pass")

    def summary(self) -> str:
        """One line: each part's verdict, every failing observation interval, and the cTE/dTE split."""
        parts = []
        for res in (self.mtie, self.tdev):
            if res is None:
                continue
            bad = res.failing_tau_s
            where = f" at tau {', '.join(f'{t:g}' for t in bad)} s" if bad.size else ""
            label = f"{res.metric.upper()}{' of dTE_L' if self.filtered else ''}"
            word = {"pass": "pass", "fail": "fail", "incomplete": "incomplete", "not evaluated": "not evaluated"}[res.status]
            parts.append(f"{label} {word}{where}")
        if self.time_error is not None:
            t = self.time_error
            split = ""
            if self.split is not None:
                split = (f" (cTE {self.split.cte_s * 1e9:+.1f} ns, max |dTE| {self.split.max_abs_dte_s * 1e9:.1f} ns)")
            parts.append(f"max |TE| {t.max_abs_te_s * 1e9:.1f} ns {'<=' if t.passed else '>'} "
                         f"{t.limit_s * 1e9:.0f} ns{split}")
        for lim in self.limits:
            label = {"cte": "|cTE| (1000 s)", "max_abs_te_l": "max |TE_L|", "dte_h_pp": "dTE_H p-p"}[lim.quantity]
            parts.append(f"{label} {lim.value_s * 1e9:.1f} ns {'<=' if lim.passed else '>'} {lim.limit_s * 1e9:.0f} ns")
        for note in self.not_covered:
            parts.append(f"not covered: {note}")
        for note in self.not_evaluated:
            parts.append(f"not evaluated: {note}")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {
            "clock": self.clock,
            "mtie": None if self.mtie is None else self.mtie.to_dict(),
            "tdev": None if self.tdev is None else self.tdev.to_dict(),
            "time_error": None if self.time_error is None else self.time_error.to_dict(),
            "limits": [lim.to_dict() for lim in self.limits],
            "split": None if self.split is None else self.split.to_dict(),
            "offset": self.offset,
            "filtered": self.filtered,
            "not_evaluated": list(self.not_evaluated),
            "not_covered": list(self.not_covered),
            "passed": self.passed,
            "verdict": verdict_word(self.status),
            "summary": self.summary(),
        }




def _status(v: ClockVerdict) -> str:
    """The verdict of :class:`ClockVerdict` from its parts (its docstring)."""
    masks = [r for r in (v.mtie, v.tdev) if r is not None]
    scalar = ([v.time_error.passed] if v.time_error is not None else []) + [lim.passed for lim in v.limits]
    if any(r.status == "fail" for r in masks) or not all(scalar):
        return "fail"
    if not scalar and all(r.status == "not evaluated" for r in masks):
        return "not evaluated"
    if v.not_covered or any(r.status != "pass" for r in masks):
        return "incomplete"
    return "pass"
