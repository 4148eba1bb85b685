"""Station integrity on the real IGS stations: clean-day false alarms and faults injected on one satellite.

Run ``python -m chronofuse.experiments.integrity_stations [OUT_DIR]`` (default ``docs/integrity``): it writes
``stations_table.md`` and ``stations.json``, the measurements quoted in the documentation, and the tests
(``tests/integrity/test_station_integrity.py``) call the same functions on fewer cases.

* **Clean day** (:func:`clean_day`): the whole day after ``train_s`` of training through the station's
  identification; the station-level false-alarm rate is the number of raises (a satellite named, the receiver
  clock raised, or an unidentified alarm starting) per tested epoch, with its Clopper-Pearson interval.
* **Faults** (:func:`fault_cases`, :func:`run_case`): a fault of :data:`FAULTS` added to every code of one
  satellite from an onset on, on a stretch of ``before`` epochs before and ``after`` after the onset, with the
  noise fitted on the day's training stretch. A case is *named alone* when the satellite is named, never
  before the onset, and no other satellite is named during the stretch that the same stretch without the
  fault does not name; the delay is from the onset to the first epoch it is named.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from chronofuse.integrity.station_identify import MIN_TESTED_SATELLITES, IdentificationSettings, StationIdentification

__all__ = ["FAULTS", "fault_bias_s", "clean_day", "fault_cases", "run_case", "clopper_pearson", "Case", "main"]

#: Faults injected on one satellite: name -> (shape, size) with the fault in seconds at ``t`` seconds after onset.
FAULTS = {
    "step 30 ns": lambda t: np.full_like(t, 30e-9),
    "step 100 ns": lambda t: np.full_like(t, 100e-9),
    "ramp 1 ns/s": lambda t: 1e-9 * t,
    "drag 0.041 ns/s^2": lambda t: 0.5 * 0.041e-9 * t**2,
}


def fault_bias_s(kind: str, t_ns: np.ndarray, onset_ns: int) -> np.ndarray:
    """The fault ``kind`` of :data:`FAULTS` at ``t_ns`` (0 before ``onset_ns``), seconds."""
    t = (np.asarray(t_ns, dtype=np.int64) - int(onset_ns)) / 1e9
    return np.where(t >= 0, FAULTS[kind](np.maximum(t, 0.0)), 0.0)


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact binomial interval of ``k`` successes in ``n`` trials."""
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def _fit(channels, settings: IdentificationSettings, train_epochs: int) -> StationIdentification:
    training = np.zeros(channels.n_epochs, dtype=bool)
    training[:train_epochs] = True
    return StationIdentification(channels.channels, settings).fit(dict(channels.frame(), training=training))


def clean_day(channels, settings: IdentificationSettings, train_s: float = 6 * 3600.0) -> dict:
    """The clean day (module docstring): ``raises``, ``tested``, ``rate`` with ``interval`` (95 %),
    ``alarm_fraction`` (epochs in alarm), ``named`` (satellites ever named), the fitted stage (``stage``)
    and the receiver clock's raises (``clock_raises``)."""
    from chronofuse.integrity.station_mode import station_integrity

    doc, out = station_integrity(None, None, channels.position_m, channels=channels, train_s=train_s,
                                 window=settings.window, pfa=settings.pfa, test=settings.test,
                                 reserved=settings.reserved, check_position=False)
    state = np.asarray([s for s in _states(doc, out, channels)], dtype=object)
    tested = np.isin(state, ("ok", "alarm"))
    alarm = state == "alarm"
    unidentified = np.asarray(out["unidentified"], dtype=bool)
    raises = sum(e["kind"] == "raise" for e in doc["channel_events"]) + int(
        (unidentified & ~np.r_[False, unidentified[:-1]]).sum())
    n = int(tested.sum())
    clock = [int(np.searchsorted(channels.t_ns, a["t_ns"])) for a in doc["receiver_clock"]["alarms"]]
    return {"raises": raises, "satellite_raises": raises - len(clock), "clock_raise_epochs": clock, "tested": n, "rate": raises / max(n, 1), "interval": clopper_pearson(raises, n),
            "alarm_fraction": float(alarm.sum() / max(n, 1)), "named": sorted({f["channel"] for f in doc["faulty"]}),
            "clock_raises": len(doc["receiver_clock"]["alarms"]), "pfa": settings.pfa, "test": settings.test,
            "n_channels": len(channels.channels), "codes": list(channels.codes), "untested": doc["untested"]}


def _states(doc, out, channels):
    states = np.asarray(out["identification_state"], dtype=object).copy()
    t_ns = channels.t_ns
    for a in doc["receiver_clock"]["alarms"]:
        states[np.searchsorted(t_ns, a["t_ns"])] = "alarm"
    return states


@dataclass(frozen=True)
class Case:
    """One injected fault: ``kind`` of :data:`FAULTS` on ``satellite`` from grid epoch ``onset``."""

    kind: str
    satellite: str
    onset: int


def fault_cases(channels, n_onsets: int, seed: int, *, first: int, before: int = 60, after: int = 60,
                kinds=tuple(FAULTS)) -> list[Case]:
    """``n_onsets`` onsets per kind, drawn after epoch ``first``, each on a satellite drawn among those with
    a channel observed over the whole stretch ``[onset - before, onset + after)``."""
    rng = np.random.default_rng(seed)
    sats = list(dict.fromkeys(s for s, _ in channels.channels))
    out = []
    for kind in kinds:
        for _ in range(n_onsets):
            while True:
                onset = int(rng.integers(first + before, channels.n_epochs - after))
                seen = [s for s in sats
                        if np.isfinite(channels.bias_s[channels.rows_of(s), onset - before:onset + after]).all(axis=1).any()]
                if seen:
                    break
            out.append(Case(kind, seen[int(rng.integers(len(seen)))], onset))
    return out


def run_case(stage: StationIdentification, channels, case: Case, *, before: int = 60, after: int = 60) -> dict:
    """One case (module docstring) through a fitted ``stage``: ``named_alone``, ``named``, ``early`` (the
    satellite named before the onset), ``delay_s`` (NaN: never named), ``others`` (other satellites named that
    the same stretch without the fault does not name: a satellite the real data already name, such as BOR1's
    G08, is not the fault's doing),
    ``unavailable`` (epochs ``unavailable`` although the same stretch without the fault had more than
    :data:`MIN_TESTED_SATELLITES` satellites tested, so that one left out leaves enough)."""
    start, stop = case.onset - before, min(channels.n_epochs, case.onset + after)
    part = channels.epochs(start, stop)
    rows = channels.rows_of(case.satellite)
    bias = part.bias_s.copy()
    bias[rows] += fault_bias_s(case.kind, part.t_ns, int(channels.t_ns[case.onset]))[None, :]
    frame = dict(part.frame(), training=np.zeros(part.n_epochs, dtype=bool))
    out = stage.run(dict(frame, channel_bias_s=bias))
    clean = stage.run(frame)
    named = [set(filter(None, s.split(","))) for s in out["named"]]
    named_clean = set().union(*(set(filter(None, s.split(","))) for s in clean["named"]))
    k0 = before
    early = any(case.satellite in named[k] for k in range(k0))
    hits = [k for k in range(k0, part.n_epochs) if case.satellite in named[k]]
    others = set().union(*named) - {case.satellite} - named_clean
    states = np.asarray(out["identification_state"])
    clean_sats = np.asarray(clean["n_satellites_tested"])
    unavailable = int(((states == "unavailable") & (clean_sats > MIN_TESTED_SATELLITES)).sum())
    delay = (hits[0] - k0) * part.interval_s if hits else math.nan
    return {"kind": case.kind, "satellite": case.satellite, "onset": case.onset, "named": bool(hits),
            "named_alone": bool(hits) and not others and not early, "early": early, "delay_s": delay,
            "others": sorted(others), "unavailable": unavailable}


def _station_rows(name, station, tests, pfa, n_onsets, seed):
    from chronofuse.io.station_channels import station_channels

    channels = station_channels(station.observations(), station.navigation(), station.reference_arp_m)
    rows = {"station": name, "make": station.make, "receiver": station.receiver, "codes": list(channels.codes)}
    train = int(round(6 * 3600 / channels.interval_s))
    for test in tests:
        settings = IdentificationSettings(pfa=pfa, test=test, reserved=0.1)
        t0 = time.perf_counter()
        clean = clean_day(channels, settings)
        clean["seconds"] = time.perf_counter() - t0
        stage = _fit(channels, settings, train)
        cases = [run_case(stage, channels, c) for c in fault_cases(channels, n_onsets, seed, first=train)]
        rows[test] = {"clean": clean, "cases": cases}
    return rows


def _summary(rows: list[dict], tests) -> str:
    lines = ["| station | receiver | test | clean raises / tested epochs | rate (95 % interval) | cases named alone | "
             "named before onset | median delay (s) by fault |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for test in tests:
            c, cases = r[test]["clean"], r[test]["cases"]
            lo, hi = c["interval"]
            alone = sum(x["named_alone"] for x in cases)
            early = sum(x["early"] for x in cases)
            delays = []
            for kind in FAULTS:
                d = [x["delay_s"] for x in cases if x["kind"] == kind]
                finite = [v for v in d if math.isfinite(v)]
                delays.append(f"{kind}: {np.median(finite):.0f} ({len(finite)}/{len(d)})" if finite else f"{kind}: - (0/{len(d)})")
            lines.append(f"| {r['station']} | {r['receiver']} | {test} | {c['raises']} / {c['tested']} | {c['rate']:.2e} "
                         f"({lo:.1e}-{hi:.1e}) | {alone}/{len(cases)} | {early} | {'; '.join(delays)} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Write ``stations_table.md`` and ``stations.json`` (module docstring) in ``argv[0]`` (default docs/integrity)."""
    from chronofuse.experiments.real_stations import load_stations

    argv = sys.argv[1:] if argv is None else argv
    out_dir = Path(argv[0] if argv else "docs/integrity")
    folder = Path(__file__).resolve().parents[3] / "tests" / "data" / "rinex" / "igs"
    tests, pfa, n_onsets, seed = ("chi-square", "glr"), 1e-3, 3, 18
    rows = [_station_rows(name, st, tests, pfa, n_onsets, seed) for name, st in load_stations(folder).items()]
    table = _summary(rows, tests)
    (out_dir / "stations.json").write_text(json.dumps(rows, indent=1, default=float))
    (out_dir / "stations_table.md").write_text(
        f"<!-- written by python -m chronofuse.experiments.integrity_stations: station P_fa {pfa:g} per epoch, "
        f"6 h training, {n_onsets} onsets per fault, seed {seed} -->\n\n{table}\n")
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
