"""The monitor at 200 receivers x 10 Hz in one process: does it keep up, and what share of one core does
it take?

Two hundred replays of the M8T timing capture at 10x its pace (each a 10 Hz receiver; each burst sent
when its epoch comes, io/replay.py) run through the whole live path: sources in threads, framing, UBX
decoding, qualification, the HOD detector, UTC/leap consensus, events, the SQLite WAL log with a commit
before each acknowledgement. Measured over the steady part of the run (after ``warmup_s``): the process's
CPU time (all threads) over wall time (the share of a core), epochs acknowledged per second against the
2,000 sent, and the delay from an epoch's first bytes to its acknowledgement (median, 95th percentile,
and the median of the last fifth of the run: a monitor that falls behind shows a delay that grows).
ratio = one core / the share of a core the epochs sent need (CPU per acknowledged epoch x 2,000/s:
on a shared machine the process may get less than a core, and then falls behind for want of CPU, not
for its own cost; whether it kept up, and the load average, are in the note). The capture lasts 15 s at 10 Hz, so the
steady window is from ``warmup_s`` to 14 s. ``quick``: 48 receivers.

Run alone: ``.venv/bin/python benchmarks/bench_monitor_scale.py [--quick] [--receivers N] [--seconds S]``.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from chronofuse.io.replay import ReplaySource
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.log import EpochLog

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_readers import _gpsd_dir  # noqa: E402

RATE_HZ = 10.0  # the capture is 1 Hz, replayed at 10x


def measure(receivers: int, seconds: float, warmup_s: float = 4.0) -> dict:
    path = _gpsd_dir() / "u-blox-m8t-time.log"
    marks: list[tuple[float, int, float]] = []  # (monotonic, acknowledged so far, process CPU)
    delays: list[tuple[float, float]] = []  # (monotonic at ack, delay s)

    def ack(records):
        now_ns, now = time.time_ns(), time.monotonic()
        delays.extend((now, (now_ns - r["received_unix_ns"]) / 1e9) for r in records)

    def tick(mon):
        marks.append((time.monotonic(), mon.acknowledged, time.process_time()))

    first = time.monotonic() + 2.0  # every replay's first epoch at one instant, as GPS-locked receivers send
    sources = [ReplaySource(path, name=f"rx{i:03d}", speed=RATE_HZ, start_at=first) for i in range(receivers)]
    with tempfile.TemporaryDirectory() as tmp:
        log = EpochLog(Path(tmp) / "bench.db")
        mon = Monitor(sources, MonitorSettings(), log=log, on_ack=ack)
        start = first
        mon.run(duration_s=seconds + 2.0, on_tick=tick, tick_s=0.5)
        log.close()
    span_s = 150.0 / RATE_HZ  # the capture's 151 epochs at 10 Hz: every replay runs this long
    end_s = min(seconds, span_s - 1.0)
    steady = [m for m in marks if warmup_s <= m[0] - start <= end_s]
    (t0, n0, c0), (t1, n1, c1) = steady[0], steady[-1]
    window = t1 - t0
    late = [d for t, d in delays if start + warmup_s <= t <= start + end_s]
    tail = [d for t, d in delays if t1 - window / 5 <= t <= t1]
    return {"receivers": receivers, "window_s": window, "core_share": (c1 - c0) / window,
            "cpu_per_epoch_s": (c1 - c0) / max(n1 - n0, 1),
            "epochs_per_s": (n1 - n0) / window, "sent_per_s": receivers * RATE_HZ,
            "delay_median_s": statistics.median(late), "delay_p95_s": sorted(late)[int(0.95 * len(late))],
            "delay_tail_median_s": statistics.median(tail)}


def run(quick: bool = False, receivers: int | None = None, seconds: float | None = None) -> list[dict]:
    n = receivers or (48 if quick else 200)
    m = measure(n, seconds or (12.0 if quick else 15.5))
    keeps_up = m["epochs_per_s"] >= 0.95 * m["sent_per_s"] and m["delay_tail_median_s"] < 2.0
    needed = m["cpu_per_epoch_s"] * m["sent_per_s"]  # the share of a core all the epochs sent need
    load = os.getloadavg()[0]
    return [{
        "name": f"monitor {n} receivers x {RATE_HZ:.0f} Hz (M8T replays), one process",
        "ours_s": needed * m["window_s"],
        "baseline": "one core over the same wall time",
        "baseline_s": m["window_s"],
        "ratio": float(1.0 / needed),
        "target": ">= 1: the CPU every epoch sent needs fits one core",
        "passed": bool(needed < 1.0),
        "note": (f"{m['cpu_per_epoch_s'] * 1e3:.3f} ms CPU per epoch -> {needed:.0%} of a core for "
                 f"{m['sent_per_s']:,.0f} epochs/s; {'kept up' if keeps_up else 'fell behind'} under load average "
                 f"{load:.1f}: {m['core_share']:.0%} of a core used; {m['epochs_per_s']:,.0f} epochs/s acknowledged of "
                 f"{m['sent_per_s']:,.0f} sent; delay first bytes -> acknowledged: median {m['delay_median_s']:.2f} s, "
                 f"p95 {m['delay_p95_s']:.2f} s, last fifth {m['delay_tail_median_s']:.2f} s "
                 f"(steady window {m['window_s']:.1f} s)"),
    }]


if __name__ == "__main__":  # pragma: no cover
    args = sys.argv[1:]
    pick = {a.split("=")[0]: a.split("=")[1] for a in args if "=" in a}
    for row in run(quick="--quick" in args, receivers=int(pick["--receivers"]) if "--receivers" in pick else None,
                   seconds=float(pick["--seconds"]) if "--seconds" in pick else None):
        print(row)
