"""An epoch the integrity test never checked is never "usable", never "no alarm" and never fed to chronyd:
the training stretch, a training that failed, a source without a clock bias (NMEA, a u-blox stream without
NAV-CLOCK). Each names why; the tested epochs after them are the positive control."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from _real_parts import REPO
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.io.replay import ReplaySource, SharedStart
from chronofuse.monitor.chrony import feeding
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.metrics import metrics_text
from chronofuse.monitor.status import status_document

from .conftest import receivers_dir, ubx_epochs, ubx_stream

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)
M8T = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"  # NMEA and UBX without NAV-CLOCK: no clock bias


def _bias(steps, seed, anomaly=None):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    return inject(x, anomaly, 1.0) if anomaly is not None else x


def _run(tmp_path, path, settings, speed=50.0):
    acked, events = [], []
    mon = Monitor([ReplaySource(path, name="rx", speed=speed, start_at=SharedStart(lead_s=0.2))], settings,
                  on_ack=acked.extend, on_event=events.append, hold_s=60.0)
    mon.run(duration_s=60)
    return mon, acked, events


def test_a_step_inside_the_training_stretch_is_not_usable_nor_fed_and_names_training(tmp_path):
    path = tmp_path / "step.ubx"
    path.write_bytes(ubx_stream(_bias(200, 1, Anomaly("step", 30.0, offset_s=2e-6))))
    _, acked, _ = _run(tmp_path, path, MonitorSettings())  # the default 120 s training stretch
    assert len(acked) == 200
    training = [r for r in acked if "training" in r["events"]]
    assert len(training) == 120
    # was usable in 200 of 200 epochs, the step never alarmed
    assert not any(r["usable"] for r in training)
    assert all(r["reasons"] == ["integrity not tested (training)"] for r in training)
    assert not any(feeding(r) for r in training)
    tested = [r for r in acked if r["state"] in ("ok", "alarm")]
    assert tested and all(r["usable"] == (r["state"] == "ok") for r in tested)  # the positive control
    assert any(feeding(r) for r in tested)


def test_a_training_that_fails_is_an_event_and_its_epochs_stay_untested(tmp_path):
    # one epoch every 2 s: the 30 s stretch holds 15 epochs, fewer than window + 3 = 23
    bias = _bias(60, 2)
    path = tmp_path / "slow.ubx"
    path.write_bytes(b"".join(ubx_epochs(bias[k:k + 1], start_tow_s=100_000 + 2 * k)[0] for k in range(60)))
    mon, acked, events = _run(tmp_path, path, MonitorSettings(train_s=30.0), speed=100.0)
    failed = [e for e in events if e.kind == "training_failed"]
    assert len(failed) == 1 and "need at least window + 3 = 23" in failed[0].detail, failed
    assert acked and not any(r["usable"] for r in acked) and not any(feeding(r) for r in acked)
    after = [r for r in acked if "training failed" in r["events"]]
    assert after and all("integrity not tested (training failed)" in r["reasons"] for r in after)
    entry = status_document(mon)["receivers"][0]
    text = metrics_text(status_document(mon)).decode()
    assert entry["last"]["state"] == "unavailable"
    assert 'chronofuse_receiver_alarm{receiver="rx"}' not in text  # not "no alarm": there is no sample
    assert 'chronofuse_receiver_integrity_tested{receiver="rx"} 0.0' in text


def test_a_source_without_a_clock_bias_is_never_usable_nor_fed(tmp_path):
    _, acked, _ = _run(tmp_path, M8T, MonitorSettings(), speed=50.0)
    assert len(acked) == 151  # every epoch qualified (a timing receiver, fix, GDOP, satellites)
    assert all(r["qualified"] for r in acked)
    assert not any(r["usable"] for r in acked) and not any(feeding(r) for r in acked)
    assert all(r["reasons"] == ["integrity not tested (no clock bias)"] for r in acked)


def test_the_chrony_feed_of_an_untested_source_sends_nothing(tmp_path):
    out = subprocess.run([sys.executable, "-m", "chronofuse", "monitor", "--replay", str(M8T), "--replay-speed", "50",
                          "--chrony-sock", str(tmp_path / "none.sock"), "--no-table", "--json"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120, env={"PYTHONPATH": str(REPO / "src"),
                                                                           "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr
    chrony = json.loads(out.stdout)["chrony"]
    assert chrony["samples_sent"] == 0 and chrony["send_errors"] == 0  # none was even tried


def test_a_training_stretch_too_short_for_the_window_is_refused_naming_the_option(tmp_path):
    path = tmp_path / "rx.ubx"
    path.write_bytes(ubx_stream(np.zeros(30)))
    out = subprocess.run([sys.executable, "-m", "chronofuse", "monitor", "--replay", str(path), "--train", "5",
                          "--no-table"], cwd=tmp_path, capture_output=True, text=True, timeout=60,
                         env={"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "--train == 5 s is too short" in out.stderr and "--window" in out.stderr
    assert "train_s" not in out.stderr
