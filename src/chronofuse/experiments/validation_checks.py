"""The verdicts of ``chronofuse validate``: each check, its criterion, the measured value and PASS or FAIL.

:func:`checks` reads the numbers of :func:`chronofuse.experiments.validation.run_validation`. Criteria:

* Stable32's published tables (the GPS 1PPS record's ADEV, MDEV, TDEV; the Cs 5071A record's MTIE and
  TDEV): every value within half a unit of the table's last printed digit (Stable32 prints 5 significant
  digits), and, for the GPS tables, the same number of terms at every tau.
* The open-sky receiver model against the GPS record: the analytic ADEV of the qErr-corrected 1PPS within
  5 % of Stable32's OADEV table up to 8192 s (the model's least-squares fit); the simulated receiver's
  ADEV within 15 % of Stable32's at tau <= 100 s (at least 200 Allan terms there even in a quick run, so
  the band is several standard deviations wide); the raw 1PPS (its 48 MHz sawtooth left in) 1.6 to 2.2
  times the corrected one at 1 s (a sawtooth of 6.0 ns rms on 6.1 ns).
* Each oscillator preset's simulated OADEV against theory: within 5 % at tau <= 64 s (thousands of degrees
  of freedom there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Check", "checks", "printed_precision_misses"]


@dataclass(frozen=True)
class Check:
    """One verdict: ``name``, the ``criterion`` in words, the measured ``value`` (as printed), ``passed``."""

    name: str
    criterion: str
    value: str
    passed: bool

    def to_dict(self) -> dict:
        return {"name": self.name, "criterion": self.criterion, "value": self.value,
                "verdict": "PASS" if self.passed else "FAIL"}


def printed_precision_misses(ours, table, digits: int = 5) -> int:
    """How many of ``ours`` differ from ``table`` by more than half a unit of the table's last printed digit."""
    ours, table = np.asarray(ours, dtype=float), np.asarray(table, dtype=float)
    tol = 0.5 * 10.0 ** (np.floor(np.log10(np.abs(table))) - (digits - 1))
    return int((np.abs(ours - table) > tol * 1.0001).sum())


def _stable32(name: str, ours, table) -> Check:
    misses = printed_precision_misses(ours, table)
    worst = float(np.max(np.abs(np.asarray(ours) / np.asarray(table) - 1.0)))
    return Check(name, "every value equals Stable32's table to its 5 printed digits",
                 f"{len(table) - misses}/{len(table)} values, worst relative difference {worst:.1e}", misses == 0)


def checks(numbers: dict) -> list[Check]:
    """Every verdict on one validation run's numbers (see the module docstring for the criteria)."""
    out = []
    gps = numbers["gps"]
    for name in ("adev", "mdev", "tdev"):
        out.append(_stable32(f"GPS 1PPS record: {name.upper()} against Stable32", gps["ours"][name]["dev"],
                             gps["stable32"][name]["dev"]))
        same = np.array_equal(gps["ours"][name]["n"], gps["stable32"][name]["n"])
        out.append(Check(f"GPS 1PPS record: {name.upper()} terms per tau", "the same number of terms as Stable32",
                         "equal" if same else "different", bool(same)))
    cs = numbers["cs5071a"]
    for name in ("mtie", "tdev"):
        out.append(_stable32(f"Cs 5071A record: {name.upper()} against Stable32", cs[name]["ours"]["dev"],
                             cs[name]["stable32"]["dev"]))
    rec = numbers["receiver"]
    misfit = rec["record"]["analytic_worst_misfit"]
    out.append(Check("open-sky receiver model: analytic ADEV against the GPS record",
                     "within 5 % of Stable32's OADEV up to 8192 s", f"worst |ln ratio| {misfit:.3f}", misfit < 0.05))
    tau = np.asarray(rec["tau"])
    ratio = np.asarray(rec["ratio_sim_to_stable32"])[tau <= 100.0]
    worst = float(np.max(np.abs(ratio - 1.0))) if ratio.size else float("nan")
    out.append(Check("open-sky receiver model: simulated ADEV against the GPS record",
                     "within 15 % of Stable32's ADEV at tau <= 100 s", f"worst {worst:.1%} over {ratio.size} taus",
                     bool(ratio.size) and worst <= 0.15))
    raw = float(rec["ratio_raw_to_corrected"][0])
    out.append(Check("open-sky receiver model: the raw 1PPS keeps the sawtooth",
                     "ADEV(1 s) of the raw 1PPS 1.6 to 2.2 times the corrected one", f"{raw:.2f}", 1.6 < raw < 2.2))
    for name, osc in sorted(numbers["oscillators"].items()):
        tau = np.asarray(osc["tau"])
        ratio = np.asarray(osc["ratio_sim_to_theory"])[tau <= 64.0]
        worst = float(np.max(np.abs(ratio - 1.0))) if ratio.size else float("nan")
        out.append(Check(f"oscillator preset {name}: simulated OADEV against theory",
                         "within 5 % at tau <= 64 s", f"worst {worst:.1%} over {ratio.size} taus",
                         bool(ratio.size) and worst <= 0.05))
    return out
