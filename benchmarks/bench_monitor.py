"""The monitor holding 16 receivers at 10 Hz: CPU per receiver, measured with replayed recordings.

Sixteen replays of a real u-blox capture at 10x its pace (a 1 Hz receiver becomes a 10 Hz one) run
through the whole live path (sources in threads, framing, pyubx2/pynmeagps decoding, qualification,
HOD detector step, consensus, the SQLite WAL log with a commit before each acknowledgement). The CPU
time of the process (all threads) per epoch logged, times one receiver's epoch rate, is the share of a
core one receiver costs, against the budget of 10 %: ratio = budget / measured (>= 1 passes). (Per
epoch, because on a shared, loaded machine the replays may fall behind their pace; the note also gives
CPU / wall / receivers and how many epochs were logged of those sent.) Cases: the F9P capture (NAV-CLOCK + RXM-RAWX, the
detector stepping) and the M8T timing capture (TIM-TP, NAV-SAT, NAV-TIMELS...). ``quick``: 10 s runs.

Run alone: ``.venv/bin/python benchmarks/bench_monitor.py [--quick]``.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from chronofuse.io.inspect import read_capture
from chronofuse.io.sources import FileSource
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.log import EpochLog
from chronofuse.timescale import NS_PER_S

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_readers import _gpsd_dir  # noqa: E402

RECEIVERS = 16
SPEED = 10.0
BUDGET_CORE_PER_RECEIVER = 0.10


def run(quick: bool = False) -> list[dict]:
    duration_s = 10.0 if quick else 30.0
    rows = []
    for capture_name in ("ublox-zed-f9p_hpg1.11.log", "u-blox-m8t-time.log"):
        path = _gpsd_dir() / capture_name
        capture = read_capture(path)
        span_s = (capture.rows["gps_ns"][-1] - capture.rows["gps_ns"][0]) / NS_PER_S
        rate_hz = capture.n_epochs / span_s * SPEED
        bytes_s = path.stat().st_size / span_s * SPEED
        sources = [FileSource(path, name=f"rx{i:02d}", rate_bytes_s=bytes_s, chunk=4096) for i in range(RECEIVERS)]
        with tempfile.TemporaryDirectory() as tmp:
            log = EpochLog(Path(tmp) / "bench.db")
            mon = Monitor(sources, MonitorSettings(), log=log)
            wall0, cpu0 = time.perf_counter(), time.process_time()
            # a recording shorter than the run ends by itself (its last epochs flushed at the end of file)
            mon.run(duration_s=min(duration_s, span_s / SPEED + 5.0))
            wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
            log.close()
        # CPU per epoch logged, times the epochs one receiver sends per second: the share of a core one
        # receiver costs, whether or not a loaded machine let the replay keep its pace
        per_epoch_s = cpu / max(mon.acknowledged, 1)
        per_receiver = per_epoch_s * rate_hz
        rows.append({
            "name": f"monitor {RECEIVERS} x {rate_hz:.0f} Hz ({capture_name})",
            "ours_s": cpu,
            "baseline": f"budget {BUDGET_CORE_PER_RECEIVER:.0%} core/receiver",
            "baseline_s": BUDGET_CORE_PER_RECEIVER * RECEIVERS * wall,
            "ratio": float(BUDGET_CORE_PER_RECEIVER / per_receiver),
            "target": ">= 1 (under 10 % of a core per receiver)",
            "passed": bool(per_receiver < BUDGET_CORE_PER_RECEIVER),
            "note": (f"{per_epoch_s * 1e3:.2f} ms CPU per epoch -> {per_receiver:.2%} of a core per receiver at "
                     f"{rate_hz:.0f} Hz; process CPU / wall / receivers = {cpu / wall / RECEIVERS:.2%} over {wall:.1f} s; "
                     f"{mon.acknowledged:,} epochs logged of about {RECEIVERS * rate_hz * wall:,.0f} sent"),
        })
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run(quick="--quick" in sys.argv):
        print(row)
