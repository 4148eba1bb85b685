"""detect_file: the library call behind `chronofuse detect` gives the document the command prints, and the
mode follows the file."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.modes import EARTH_SURFACE_M, detect_file, parse_position
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.validation import InputDataError

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
STATION_0759_M = "-3976219.5082,3382372.5671,3652512.9849"  # the RINEX header's approximate position


EXIT = {"ok": 0, "alarm": 1, "unavailable": 3}


def _cli_json(*args) -> dict:
    result = CliRunner().invoke(app, ["detect", *map(str, args), "--json"])
    doc = json.loads(result.stdout)
    assert result.exit_code == EXIT[doc["state"]], result.output
    return doc


def test_a_csv_gives_the_document_the_command_prints_and_finds_the_step(tmp_path):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=600, trials=1, seed=2).measured_s[0]
    x = inject(x, Anomaly("step", 400.0, offset_s=1e-7), 1.0)
    path = tmp_path / "b.csv"
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{float(v)!r}\n" for k, v in enumerate(x)))
    doc = detect_file(path, 1.0, h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
    cli = _cli_json(path, "--rate", 1, "--h0", NOISE.h0, "--hm2", NOISE.hm2, "--sigma-rho", NOISE.sigma_rho_m)
    assert json.loads(json.dumps(doc)) == cli
    assert doc["mode"] == "detection" and any(400 <= a["t"] <= 402 for a in doc["alarms"])


def test_a_ubx_capture_with_training_gives_the_command_document(real_data):
    path = real_data / "receivers/gpsd/navisys-gr701w.log"
    doc = detect_file(path, 1.0, train_s=40)
    assert json.loads(json.dumps(doc)) == _cli_json(path, "--rate", 1, "--train", 40)
    assert doc["mode"] == "detection" and doc["n_epochs"] == 80


def test_rinex_observations_with_nav_and_position_select_identification(real_data):
    rtk = real_data / "receivers/rinex/rtklib"
    doc = detect_file(rtk / "07590920.05o", None, train_s=1200, window=10, nav=rtk / "07590920.05n",
                      position_m=np.array([float(v) for v in STATION_0759_M.split(",")]))
    assert doc["mode"] == "identification" and doc["n_epochs"] == 120
    assert {"faulty", "untested"} <= set(doc)


def test_a_position_is_three_ecef_metres_near_the_earth_surface_given_as_text_or_numbers():
    xyz = parse_position(STATION_0759_M)
    np.testing.assert_array_equal(parse_position(list(xyz)), xyz)
    assert EARTH_SURFACE_M[0] <= np.linalg.norm(xyz) <= EARTH_SURFACE_M[1]
    for bad, fragment in (("1,2", "three finite numbers"), ("a,b,c", "ECEF metres"),
                          ((48.1, 11.6, 520.0), "from the Earth's centre")):
        with pytest.raises(InputDataError, match=fragment):
            parse_position(bad)


def test_the_noise_model_or_a_training_stretch_is_required_and_options_must_fit_the_file(tmp_path, real_data):
    path = tmp_path / "b.csv"
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{k},0\n" for k in range(50)))
    with pytest.raises(ValueError, match="train_s"):
        detect_file(path, 1.0, h0=1e-18)
    with pytest.raises(ValueError, match="rate_hz == 0"):
        detect_file(path, 0.0, train_s=10)
    with pytest.raises(InputDataError, match="b.csv: nav and position_m need a RINEX observation file"):
        detect_file(path, 1.0, train_s=10, position_m=STATION_0759_M)
    failed = detect_file(path, 1.0, train_s=10)  # training failed: integrity unavailable, not "no alarm"
    assert failed["state"] == "unavailable" and failed["alarms"] == [] and failed["noise"] is None
    assert "the training stretch (train_s) of 10 s holds 10 valid epochs" in failed["unavailable_reasons"][0]
    with pytest.raises(InputDataError, match="07590920.05n: this is a RINEX navigation file"):
        detect_file(real_data / "receivers/rinex/rtklib/07590920.05n", 1 / 30, train_s=1200)


def test_a_file_with_a_time_column_needs_no_rate_and_a_rounded_rate_is_not_refused(tmp_path):
    # 300 s data with --rate 0.003333 was refused; the time column gives the interval
    x = simulate_clock_bias(NOISE, interval_s=300.0, steps=200, trials=1, seed=5).measured_s[0]
    path = tmp_path / "b.csv"
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{300 * k},{float(v)!r}\n" for k, v in enumerate(x)))
    model = dict(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
    plain = detect_file(path, **model)
    assert plain["interval_s"] == 300.0 and plain["n_epochs"] == 200
    assert detect_file(path, 0.003333, **model) == plain


def test_millisecond_clock_resets_are_clock_events_not_alarms_and_detection_goes_on(tmp_path):
    # a free-running receiver clock (drift 2e-7) reset by 1 ms whenever it leaves +-0.5 ms, as the IGS
    # stations MANA, URUM and TIXJ do; a 100 ns step at 1500 s must still be found
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=3000, trials=1, seed=8).measured_s[0] + 2e-7 * np.arange(3000)
    steered = x - 1e-3 * np.floor((x + 5e-4) / 1e-3)
    resets = np.flatnonzero(np.diff(np.floor((x + 5e-4) / 1e-3))) + 1
    assert resets.size >= 1
    steered = inject(steered, Anomaly("step", 1500.0, offset_s=1e-7), 1.0)
    path = tmp_path / "steered.csv"
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{float(v)!r}\n" for k, v in enumerate(steered)))
    doc = detect_file(path, h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
    assert [e["t"] for e in doc["clock_events"]] == [float(k) for k in resets]
    assert all(e["size_s"] == -1e-3 for e in doc["clock_events"])
    alarms = [a["t"] for a in doc["alarms"]]
    assert any(1500 <= t <= 1502 for t in alarms)
    assert not set(alarms) & {float(k) for k in resets} and doc["state"] == "alarm"


def test_a_short_or_non_stationary_training_stretch_is_warned_about_and_the_model_can_be_given_back(tmp_path):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=2000, trials=1, seed=9).measured_s[0]
    path = tmp_path / "b.csv"
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{float(v)!r}\n" for k, v in enumerate(x)))
    short = detect_file(path, train_s=60)
    assert any(w.startswith("short training") for w in short["warnings"])
    long = detect_file(path, train_s=1000)
    assert long["warnings"] == []
    noisy = x + np.where(np.arange(2000) >= 500, 1.0, 0.0) * np.random.default_rng(2).normal(0, 2e-8, 2000)
    path.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{float(v)!r}\n" for k, v in enumerate(noisy)))
    changed = detect_file(path, train_s=1000)
    assert any(w.startswith("training not stationary") for w in changed["warnings"])
    # the fitted parameters, written out, give the same verdicts on the next run without training
    model = tmp_path / "noise.json"
    model.write_text(json.dumps(long))
    result = CliRunner().invoke(app, ["detect", str(path), "--noise", str(model), "--json"])
    again = json.loads(result.stdout)
    assert again["noise"]["h0"] == long["noise"]["h0"] and again["noise"]["sigma_rho_m"] == long["noise"]["sigma_rho_m"]


def test_the_stationarity_screen_stays_quiet_on_stationary_simulated_training():
    from chronofuse.integrity.modes import training_warnings

    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=1000, trials=200, seed=11).measured_s
    flagged = sum(any(w.startswith("training not") for w in training_warnings(np.diff(r, 2))) for r in x)
    assert flagged <= 2  # two-sided 0.1 % screen: 0.2 expected of 200 (measured: 0)


def test_the_gr701w_coasting_without_a_fix_is_unavailable_not_healthy(real_data):
    # the Navisys GR-701W kept reporting a clock bias after losing its fix (NAV-SOL gpsfixOK = 0)
    doc = detect_file(real_data / "receivers/gpsd/navisys-gr701w.log", h0=2e-18, hm2=1e-22, sigma_rho_m=1.0,
                      window=5)
    coasting = [u for u in doc["unavailable"] if u["reason"] == "receiver status: no valid fix"]
    assert doc["n_no_fix"] == 29 and len(coasting) == 1
    assert (coasting[0]["to_ns"] - coasting[0]["from_ns"]) // 10**9 == 28
    assert not [a for a in doc["alarms"] if coasting[0]["from_ns"] <= a["t_ns"] <= coasting[0]["to_ns"]]
