"""Identification on the two real Trimble 5700 stations with injected faults.

For each station (RTKLIB's ``07590920`` and ``30400920``: RINEX 2.10, 120 epochs at 30 s, C1 and P2),
each satellite observed at every epoch above the 15 deg mask, each code (C1, P2) and each kind of fault
(a 30 ns step, a 100 ns / 10 min ramp, a drag-off growing as 0.5 m x epoch^2 in range), the fault is
added to that one channel's clock bias from 1800 s (epoch 60) to the end, and
:func:`chronofuse.integrity.identification.identify` (window 10, P_fa 1e-3, each channel trained on its
first 40 epochs with the 90 % confidence margin of :data:`chronofuse.integrity.modes.TRAINING_CONFIDENCE`)
runs on that code's channels. A row records what was named, whether the faulty channel was named
alone, its naming delay, whether any alarm or naming of it came before the onset, and whether it stayed
raised to the end of the record by the per-channel raise/clear latch
(:func:`chronofuse.integrity.channel_latch.latch_channels`: a fault that lasts must never be cleared). Orchestration only: the table is written by
:func:`chronofuse.report.integrity_real.write_trimble_table`.

Run: ``python -m chronofuse.experiments.integrity_real [DATA_DIR] [OUT_DIR]`` (defaults: ``tests/data``
and ``docs/integrity``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.observables import channel_clock_biases_from_arrays
from chronofuse.integrity.channel_latch import latch_channels
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.identification import identify
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.modes import TRAINING_CONFIDENCE
from chronofuse.io.rinex import channel_clock_biases, read_gps_navigation, read_gps_observations

STATIONS = ("07590920", "30400920")
ONSET_S = 1800.0
INTERVAL_S = 30.0
FAULTS = {
    "step": dict(offset_s=30e-9),
    "ramp": dict(rate_s_per_s=100e-9 / 600.0),
    "drag": dict(accel_s_per_s2=1.0 / SPEED_OF_LIGHT_M_PER_S / INTERVAL_S**2),
}


def trimble_cases(data_dir: Path) -> list[dict]:
    """One row per (station, code, fault kind, satellite); see the module docstring."""
    rows = []
    base = Path(data_dir) / "receivers" / "rinex" / "rtklib"
    for station in STATIONS:
        obs_path, nav_path = base / f"{station}.05o", base / f"{station}.05n"
        obs = read_gps_observations(obs_path)
        nav = read_gps_navigation(nav_path)
        for code in obs.codes:
            biases = channel_clock_biases(obs_path, nav_path, obs.approx_position_m, code=code, observations=obs,
                                          navigation=nav)
            full = [j for j in range(len(biases.satellites)) if np.isfinite(biases.bias_s[:, j]).all()]
            for kind, size in FAULTS.items():
                for j in full:
                    sat = biases.satellites[j]
                    faulty = inject(biases.bias_s, Anomaly(kind, ONSET_S, channel=j, **size), INTERVAL_S)
                    det = HodDetector(interval_s=INTERVAL_S, window=10, pfa=1e-3, confidence=TRAINING_CONFIDENCE)
                    res = identify(channel_clock_biases_from_arrays(faulty, INTERVAL_S, biases.satellites), det)
                    onset = int(ONSET_S / INTERVAL_S)
                    own = [a["epoch"] for a in res.alarms if a["channel"] == sat]
                    blamed = int(res.blamed_at[j])
                    raised, _ = latch_channels(res)
                    rows.append({
                        "station": station, "code": code, "fault": kind, "satellite": sat,
                        "named": " ".join(res.faulty) or "-",
                        "alone": res.faulty == [sat],
                        "delay_s": (blamed - onset) * INTERVAL_S if blamed >= 0 else None,
                        "before_onset": bool(any(k < onset for k in own) or 0 <= blamed < onset),
                        "latched_to_end": bool(blamed >= 0 and raised[blamed:, j].all()),
                    })
    return rows


def main(argv: list[str]) -> None:
    from chronofuse.report.integrity_real import write_trimble_table

    data = Path(argv[0]) if argv else Path("tests/data")
    out = Path(argv[1]) if len(argv) > 1 else Path("docs/integrity")
    write_trimble_table(trimble_cases(data), out)


if __name__ == "__main__":
    main(sys.argv[1:])
