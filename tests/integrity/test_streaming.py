"""The streaming monitor: one epoch in, one verdict out; equal to the batch path; latched alarms; the
receiver's status used; `detect - --json-lines` from a pipe and a FIFO."""

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.live import stream_verdicts
from chronofuse.integrity.modes import detect_file
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.integrity.streaming import StreamingMonitor

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
MODEL = dict(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
SRC = str(Path(__file__).resolve().parents[2] / "src")


def _series(steps=3000, seed=3):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    x = x + 2e-7 * np.arange(steps)
    x = x - 1e-3 * np.floor((x + 5e-4) / 1e-3)  # millisecond steering
    x = inject(x, Anomaly("step", 2000.0, offset_s=1e-7), 1.0)
    x[[700, 701, 1200]] = np.nan
    return x


def _csv(x) -> str:
    return "t_s,clock_bias_s\n" + "".join(f"{k},{'nan' if np.isnan(v) else repr(float(v))}\n" for k, v in enumerate(x))


@pytest.mark.parametrize("train_s", [None, 1000.0])
def test_streaming_verdicts_equal_the_batch_document_on_the_same_data(tmp_path, train_s):
    x = _series()
    path = tmp_path / "b.csv"
    path.write_text(_csv(x))
    model = {} if train_s else MODEL
    batch = detect_file(path, train_s=train_s, **model)
    verdicts = list(stream_verdicts(path.read_text().splitlines(), train_s=train_s, **model))
    assert len(verdicts) == batch["n_epochs"] == x.size
    streamed_alarms = [v.t_ns for v in verdicts if v.alarm]
    assert streamed_alarms == [a["t_ns"] for a in batch["alarms"]]
    stat = {v.t_ns: v.statistic for v in verdicts}
    np.testing.assert_allclose([stat[a["t_ns"]] for a in batch["alarms"]], [a["statistic"] for a in batch["alarms"]],
                               rtol=1e-9)
    resets = [v.t_ns for v in verdicts if any(e.startswith("clock reset") for e in v.events)]
    assert resets == [e["t_ns"] for e in batch["clock_events"]] and resets
    tested = sum(v.state != "unavailable" or v.alarm for v in verdicts)
    assert tested >= batch["n_tested"]


def test_an_alarm_stays_raised_while_a_ramp_lasts_and_clears_a_window_after_it_ends():
    # a ramp's alarms stopped after 10 epochs while the range error grew
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=1500, trials=1, seed=4).measured_s[0]
    x = inject(x, Anomaly("ramp", 500.0, rate_s_per_s=1e-8, duration_s=400.0), 1.0)
    mon = StreamingMonitor(HodDetector(interval_s=1.0, window=20, **MODEL).fit())
    verdicts = [mon.step(k * 10**9, v) for k, v in enumerate(x)]
    raised = [k for k, v in enumerate(verdicts) if any(e.startswith("raise") for e in v.events)]
    cleared = [k for k, v in enumerate(verdicts) if any(e.startswith("clear") for e in v.events)]
    over = [k for k, v in enumerate(verdicts) if v.alarm]
    assert raised[0] >= 500 and raised[0] <= 505
    # the statistic is over threshold only while the window holds the ramp's start and end (about 2 x 20 epochs)
    assert sum(500 <= k < 900 for k in over) < 100
    assert all(verdicts[k].state == "alarm" for k in range(raised[0], 900))  # latched through the ramp
    assert cleared and 900 < cleared[-1] <= 900 + 3 * 20 and verdicts[-1].state == "ok"


def test_epochs_without_a_valid_fix_are_unavailable_and_do_not_look_healthy():
    # the GR-701W went on reporting a clock bias for 25 s after it lost its fix
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=200, trials=1, seed=5).measured_s[0]
    mon = StreamingMonitor(HodDetector(interval_s=1.0, window=20, **MODEL).fit())
    verdicts = [mon.step(k * 10**9, v, receiver_ok=not 100 <= k < 125) for k, v in enumerate(x)]
    assert all(verdicts[k].state == "unavailable" for k in range(100, 127))
    assert all("receiver status: no valid fix" in verdicts[k].events for k in range(100, 125))
    assert verdicts[130].state == "ok"


def _run_cli(args, stdin=None):
    env = dict(os.environ, PYTHONPATH=SRC)
    return subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "detect", *args], input=stdin,
                          capture_output=True, text=True, env=env, timeout=300)


def test_detect_from_a_pipe_prints_one_json_line_per_epoch_equal_to_the_batch_json(tmp_path):
    x = _series(steps=2500)
    text = _csv(x)
    path = tmp_path / "b.csv"
    path.write_text(text)
    model = ["--h0", str(NOISE.h0), "--hm2", str(NOISE.hm2), "--sigma-rho", str(NOISE.sigma_rho_m)]
    piped = _run_cli(["-", "--json-lines", *model], stdin=text)
    assert piped.returncode == 1, piped.stderr
    lines = [json.loads(line) for line in piped.stdout.splitlines()]
    assert len(lines) == x.size and set(lines[0]) == {"t_ns", "statistic", "threshold", "alarm", "state", "events"}
    batch = _run_cli([str(path), "--json", *model])
    doc = json.loads(batch.stdout)
    over = [r["t_ns"] for r in lines if r["statistic"] is not None and r["statistic"] > r["threshold"]]
    assert over == [a["t_ns"] for a in doc["alarms"]]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_named_pipe_is_read_as_it_is_written(tmp_path):
    fifo = tmp_path / "bias.fifo"
    os.mkfifo(fifo)
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=100, trials=1, seed=6).measured_s[0]

    def writer():
        with open(fifo, "w") as fh:
            fh.write(_csv(x))

    thread = threading.Thread(target=writer)
    thread.start()
    out = _run_cli([str(fifo), "--json-lines", "--h0", str(NOISE.h0), "--hm2", str(NOISE.hm2), "--sigma-rho", "1"])
    thread.join(timeout=60)
    assert out.returncode in (0, 1), out.stderr
    assert len(out.stdout.splitlines()) == 100


def test_a_growing_file_is_followed_until_it_stops_growing(tmp_path):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=60, trials=1, seed=7).measured_s[0]
    path = tmp_path / "growing.csv"
    text = _csv(x).splitlines(keepends=True)
    path.write_text("".join(text[:20]))

    def writer():
        import time

        for line in text[20:]:
            time.sleep(0.02)
            with open(path, "a") as fh:
                fh.write(line)

    thread = threading.Thread(target=writer)
    thread.start()
    out = _run_cli([str(path), "--json-lines", "--follow", "3", "--h0", str(NOISE.h0), "--hm2", str(NOISE.hm2),
                    "--sigma-rho", "1"])
    thread.join(timeout=60)
    assert out.returncode in (0, 1), out.stderr
    assert [json.loads(line)["t_ns"] for line in out.stdout.splitlines()] == [k * 10**9 for k in range(60)]


def test_a_training_outlier_is_left_out_of_the_fit_and_the_window_the_same_way_streaming_and_batch(tmp_path):
    x = _series()
    x[995] += 2e-7  # a 200 ns spike 5 epochs before the end of the 1000 s training: inside the first test windows
    path = tmp_path / "b.csv"
    path.write_text(_csv(x))
    batch = detect_file(path, train_s=1000.0)
    assert any(w.startswith("training outliers") for w in batch["warnings"])
    verdicts = list(stream_verdicts(path.read_text().splitlines(), train_s=1000.0))
    assert [v.t_ns for v in verdicts if v.alarm] == [a["t_ns"] for a in batch["alarms"]]
    # the spike neither blinds the fit nor alarms in the first tested windows: only the step at 2000 s alarms
    assert batch["alarms"] and all(2000 <= a["t"] <= 2025 for a in batch["alarms"])
