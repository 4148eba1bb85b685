"""Station integrity speed: a 24 h, 30 s, 4-code RINEX 3 station through identification (target under 30 s).

Ours: every epoch of NYA1 (Trimble NetR9, 2024-05-03, 2,880 epochs) with the codes G C1C, G C2W, G C5X and
E C1X through :func:`chronofuse.integrity.station_mode.station_integrity` (noise fits, identification by
exclusion, the receiver clock, the known-position check). Baseline, timed in the same process: reading the
same file and building its channels (:func:`chronofuse.integrity.station_mode.read_station`), the part any
use of the file pays; the ratio says how many file reads the whole integrity run costs. The note gives the
1-minute load average before and after (the absolute time is only comparable at equal load).

Second row: the compiled step of one code's clocks (:func:`chronofuse.integrity.station_clock.clock_step_kernel`)
against its numpy twin (``CodeClock(fast=False)``), over every epoch of NYA1's G C1C channels (target: 5x).
"""

from __future__ import annotations

from pathlib import Path

from _timing import best_of

CODES = ("G C1C", "G C2W", "G C5X", "E C1X")


def _loadavg() -> str:
    """The 1-minute load average (``/proc/loadavg``'s first field), '?' where there is none."""
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "?"


def run(quick: bool = False) -> list[dict]:
    from chronofuse.experiments.real_stations import load_stations
    from chronofuse.integrity.station_mode import read_station, station_integrity

    folder = Path(__file__).resolve().parents[1] / "tests" / "data" / "rinex" / "igs"
    st = load_stations(folder)["NYA1"]

    def read():
        return read_station(st.obs_path, st.nav_paths, st.reference_arp_m, codes=CODES)

    base = best_of(read, 1 if quick else 2)
    channels = read()

    def integrity():
        station_integrity(None, None, st.reference_arp_m, channels=channels, train_s=6 * 3600.0)

    load_before = _loadavg()
    ours = best_of(integrity, 1 if quick else 2) + base
    load_after = _loadavg()
    return [_station_row(channels, base, ours, load_before, load_after), _clock_row(channels, quick)]


def _clock_row(channels, quick: bool) -> dict:
    import numpy as np

    from chronofuse.integrity.station_clock import CodeClock

    rows = [i for i, (_, code) in enumerate(channels.channels) if code == "G C1C"]
    bias = np.ascontiguousarray(channels.bias_s[rows])
    none = np.zeros(len(rows), bool)

    def day(fast):
        clock = CodeClock(len(rows), fast=fast)
        for k in range(bias.shape[1]):
            clock.commit(clock.step(bias[:, k], none))

    day(True)  # compiled (or loaded from the cache) outside the timing
    fast, slow = best_of(lambda: day(True), 2 if quick else 3), best_of(lambda: day(False), 1 if quick else 2)
    return {"name": f"one code's clocks, {len(rows)} channels x {bias.shape[1]} epochs", "ours_s": fast,
            "baseline": "the numpy twin", "baseline_s": slow, "ratio": slow / fast, "target": ">= 5x",
            "passed": bool(slow / fast >= 5.0), "note": f"{slow / fast:.1f}x"}


def _station_row(channels, base, ours, load_before, load_after) -> dict:
    return {
        "name": f"station integrity, NYA1 24 h 30 s, {len(channels.channels)} channels of {len(CODES)} codes",
        "ours_s": ours,
        "baseline": "reading the file and building its channels",
        "baseline_s": base,
        "ratio": base / ours,
        "target": "< 30 s",
        "passed": bool(ours < 30.0),
        "note": f"{ours:.1f} s for read + integrity; /proc/loadavg {load_before} -> {load_after} (2 cores: above 2 the"
                " absolute time is stretched, the ratio much less)",
    }
