"""`chronofuse detect`: detection on CSV and UBX, the JSON document, and clear errors on bad input."""

import gzip
import json

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

runner = CliRunner()
app = typer.Typer()
detect_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding only the command under test."""


NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
MODEL = ["--h0", "2e-18", "--hm2", "1e-22", "--sigma-rho", "1.0"]
KEYS = {"mode", "n_epochs", "threshold", "window", "pfa", "alarms", "n_alarms", "n_skipped", "state",
        "unavailable_reasons", "n_tested", "n_training", "unavailable", "interval_s"}
DETECTION_KEYS = KEYS | {"clock_events", "noise", "noise_change", "warnings", "n_no_fix", "n_time_accuracy_over",
                         "max_time_acc_s", "alarm_events", "n_alarm_epochs", "time_scale"}
EXIT = {"ok": 0, "alarm": 1, "unavailable": 3}


def _bias(steps=1500, seed=1, anomaly=None):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    return inject(x, anomaly, 1.0) if anomaly is not None else x


def _write_csv(path, t, x, names=("t_s", "clock_bias_s"), scale=1.0):
    lines = [",".join(names)]
    lines += [f"{float(ti)!r},{'nan' if np.isnan(xi) else repr(float(xi) * scale)}" for ti, xi in zip(t, x)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _invoke(*args):
    return runner.invoke(app, ["detect", *map(str, args)])


def _one_line_error(result, *fragments):
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert "Traceback" not in result.output


def test_json_document_has_exactly_the_documented_keys_and_finds_a_drag_off(tmp_path):
    t = 1000.0 + np.arange(1500)
    accel = 0.5 * np.sqrt(6) * NOISE.sigma_rho_m / 299_792_458.0  # df shift 0.5 sigma_df
    path = _write_csv(tmp_path / "bias.csv", t, _bias(anomaly=Anomaly("drag", 1000.0, accel_s_per_s2=accel)))
    result = _invoke(path, *MODEL, "--json")
    assert result.exit_code == 1, result.output  # alarm
    doc = json.loads(result.stdout)
    assert set(doc) == DETECTION_KEYS
    assert doc["mode"] == "detection" and doc["n_epochs"] == 1500 and doc["window"] == 20 and doc["pfa"] == 1e-3
    assert doc["n_alarms"] == len(doc["alarms"]) and doc["n_skipped"] == 0 and doc["state"] == "alarm"
    assert doc["interval_s"] == 1.0 and doc["n_tested"] == 1498 and doc["clock_events"] == []
    alarm_t = np.array([a["t"] for a in doc["alarms"]])
    assert set(doc["alarms"][0]) == {"t_ns", "t", "statistic", "channel"}
    assert all(a["t_ns"] == round(a["t"] * 1e9) and isinstance(a["t_ns"], int) for a in doc["alarms"])
    assert (alarm_t >= 2000.0).sum() > 400  # times on the file's time axis, from the onset on
    assert 2000.0 <= alarm_t[alarm_t >= 2000.0].min() <= 2020.0
    assert (alarm_t < 2000.0).sum() <= 5  # false alarms before onset at P_fa = 1e-3
    assert all(a["statistic"] > doc["threshold"] for a in doc["alarms"])


def test_nanosecond_columns_and_column_choice_give_the_same_alarms(tmp_path):
    t = np.arange(800.0)
    x = _bias(steps=800, anomaly=Anomaly("step", 400.0, offset_s=4e-8))
    base = json.loads(_invoke(_write_csv(tmp_path / "s.csv", t, x), "--rate", 1, *MODEL, "--json").stdout)
    ns = tmp_path / "ns.csv"
    ns.write_text("t_s,other_ns,clock_bias_ns\n" + "".join(f"{float(ti)},{1.0},{float(xi) * 1e9!r}\n" for ti, xi in zip(t, x)))
    result = _invoke(ns, "--rate", 1, *MODEL, "--json")
    assert result.exit_code == 1, result.output
    doc = json.loads(result.stdout)
    assert [a["t"] for a in doc["alarms"]] == [a["t"] for a in base["alarms"]]
    np.testing.assert_allclose([a["statistic"] for a in doc["alarms"]], [a["statistic"] for a in base["alarms"]],
                               rtol=1e-6)
    picked = json.loads(_invoke(ns, "--rate", 1, "--column", "clock_bias_ns", *MODEL, "--json").stdout)
    assert [a["t"] for a in picked["alarms"]] == [a["t"] for a in base["alarms"]]
    assert any(400 <= a["t"] <= 402 for a in base["alarms"])


def test_missing_clock_biases_and_time_gaps_are_skipped_and_counted(tmp_path):
    t = np.arange(600.0)
    x = _bias(steps=600)
    x[[100, 101, 350]] = np.nan
    keep = np.ones(600, bool)
    keep[200:205] = False  # five epochs absent from the time column
    path = _write_csv(tmp_path / "gaps.csv", t[keep], x[keep])
    result = _invoke(path, "--rate", 1, *MODEL, "--json")
    doc = json.loads(result.stdout)
    assert result.exit_code == EXIT[doc["state"]], result.output
    assert doc["n_skipped"] == 8 and doc["n_epochs"] == 600
    # each gap leaves its missing epochs and the next two (no second difference yet) untested
    untested = {(u["from_ns"] // 10**9, u["to_ns"] // 10**9) for u in doc["unavailable"]}
    assert {(100, 103), (200, 206), (350, 352), (0, 1)} <= untested


def test_training_stretch_estimates_the_noise_and_the_test_still_fires(tmp_path):
    t = np.arange(6000.0)
    path = _write_csv(tmp_path / "b.csv", t, _bias(steps=6000, seed=4, anomaly=Anomaly("step", 5000.0, offset_s=1e-7)))
    result = _invoke(path, "--rate", 1, "--train", 4000, "--json")
    assert result.exit_code == 1, result.output
    doc = json.loads(result.stdout)
    times = [a["t"] for a in doc["alarms"]]
    assert min(times) >= 4000 and doc["n_training"] == 4000  # the training stretch is not tested
    assert set(doc["noise"]) == {"h0", "hm2", "sigma_rho_m", "inflation"} and all(v >= 0 for v in doc["noise"].values())
    assert 1.0 < doc["noise"]["inflation"] < 1.1  # 3998 training differences: a few per cent
    assert any(5000 <= ti <= 5002 for ti in times)
    assert sum(ti < 5000 for ti in times) <= 15


def test_human_output_is_a_table_of_alarms(tmp_path):
    path = _write_csv(tmp_path / "b.csv", np.arange(500.0), _bias(steps=500, anomaly=Anomaly("step", 300.0, offset_s=1e-7)))
    result = _invoke(path, "--rate", 1, *MODEL)
    assert result.exit_code == 1, result.output
    text = " ".join(result.stdout.split())
    assert "alarm(s)" in text and "detection mode" in text and " 300 " in text


@pytest.mark.parametrize(
    "content, extra, fragments",
    [
        ("", [], ["empty.csv", "empty"]),
        ("t_s,clock_bias_s\n0,1e-6\n1,1e-6\n2,1e-6\n", [], ["bad.csv", "window 20 is longer than the data"]),
        ("t_s,clock_bias_s\n" + "".join(f"{k},{k * 1e-9}\n" for k in (0, 1, 2, 1, 4)) + "".join(
            f"{k},0\n" for k in range(5, 40)), [], ["bad.csv:5", "not increasing"]),
        ("t_s,clock_bias_s\n" + "".join(f"{k},0\n" for k in range(30)) + "30.5,0\n", [],
         ["bad.csv", "not a whole number"]),
        ("t_s,clock_bias_s\n" + "".join(f"{k},0\n" for k in range(30)), ["--column", "bias_ns"],
         ["bad.csv", "'bias_ns' not found"]),
        ("t_s,clock_bias_s\n" + "".join(f"{k},0\n" for k in range(5)) + "5,abc\n", [],
         ["bad.csv:7", "'abc'"]),
    ],
)
def test_bad_csv_input_gives_a_one_line_error_naming_the_file(tmp_path, content, extra, fragments):
    name = "empty.csv" if not content else "bad.csv"
    path = tmp_path / name
    path.write_text(content)
    _one_line_error(_invoke(path, "--rate", 1, *MODEL, *extra, "--json"), *fragments)


def test_missing_noise_model_and_bad_options_are_refused(tmp_path):
    path = _write_csv(tmp_path / "b.csv", np.arange(100.0), _bias(steps=100))
    _one_line_error(_invoke(path, "--rate", 1, "--h0", "1e-18"), "--train")
    _one_line_error(_invoke(path, "--rate", 0, *MODEL), "--rate")
    _one_line_error(_invoke(path, "--rate", 1, *MODEL, "--pfa", 2), "--pfa")
    _one_line_error(_invoke(path, "--rate", 1, *MODEL, "--position", "1,2,3"), "RINEX")


def _nav_clock_offsets(blob: bytes) -> list[int]:
    offsets, start = [], 0
    while (k := blob.find(b"\xb5\x62\x01\x22", start)) >= 0:
        offsets.append(k)
        start = k + 1
    return offsets


def test_corrupt_ubx_frames_are_skipped_and_counted(tmp_path, real_data):
    real = real_data / "receivers" / "gpsd" / "ublox-zed-f9p_hpg1.11.log.gz"
    clean = _invoke(real, "--rate", 1, "--train", 300, "--json")
    assert clean.exit_code in (0, 1), clean.output
    clean_doc = json.loads(clean.stdout)
    blob = bytearray(gzip.decompress(real.read_bytes()))
    frames = _nav_clock_offsets(bytes(blob))
    blob[frames[300] + 10] ^= 0xFF  # a payload byte of one NAV-CLOCK frame: bad checksum
    cut = frames[-1] + 12  # the last NAV-CLOCK frame cut short
    corrupt = tmp_path / "corrupt.ubx"
    corrupt.write_bytes(bytes(blob[:cut]))
    result = _invoke(corrupt, "--rate", 1, "--train", 300, "--json")
    assert result.exit_code in (0, 1), result.output
    doc = json.loads(result.stdout)
    # one epoch lost in the middle (its frame and its grid epoch), one lost at the end (frame only)
    assert doc["n_epochs"] == clean_doc["n_epochs"] - 1
    assert doc["n_skipped"] >= clean_doc["n_skipped"] + 2


@pytest.mark.parametrize("name, fragment", [("pygpsdata-BADCK2.log", "longer than the data"),
                                            ("pygpsdata-BADEOF1.log", "no UBX NAV-CLOCK")])
def test_broken_ubx_captures_give_one_line_errors(real_data, name, fragment):
    _one_line_error(_invoke(real_data / "receivers" / "ubx" / name, "--rate", 1, *MODEL, "--json"), name, fragment)


def test_rinex_input_needs_nav_and_position_and_a_nav_file_is_not_observations(real_data):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    _one_line_error(_invoke(rtk / "07590920.05o", *MODEL), "07590920.05o", "--nav")
    _one_line_error(_invoke(rtk / "07590920.05n", "--rate", 1 / 30, *MODEL), "navigation file")


def _inject_rinex2_pseudorange(text: str, sat: str, onset: int, metres_per_epoch2: float, fields=(1, 3)) -> str:
    """Add a quadratic drag-off (metres) to the pseudoranges of ``sat`` in a RINEX 2.10 obs file with 4
    observation types (one line per satellite; ``fields`` 1 = C1, 3 = P2), from epoch ``onset`` on."""
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    epoch = 0
    while k < len(lines):
        head = lines[k]
        nsat = int(head[29:32])
        if head[28] not in "01":  # event flag with special records (comments): not an epoch
            k += 1 + nsat
            continue
        sats = head[32:68]
        k += 1
        while len(sats) < 3 * nsat:
            sats += lines[k][32:68]
            k += 1
        names = [sats[3 * i : 3 * i + 3].replace(" ", "0") for i in range(nsat)]
        for j, name in enumerate(names):
            if name == sat and epoch >= onset:
                row = lines[k + j].ljust(64)
                extra = 0.5 * metres_per_epoch2 * (epoch - onset) ** 2
                for field in fields:
                    value = float(row[16 * field : 16 * field + 14]) + extra
                    row = row[: 16 * field] + f"{value:14.3f}" + row[16 * field + 14 :]
                lines[k + j] = row.rstrip()
        k += nsat
        epoch += 1
    return "\n".join(lines) + "\n"


def test_identification_mode_names_the_satellite_with_an_injected_drag_off_on_real_rinex(tmp_path, real_data):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    clean_obs = tmp_path / "clean.05o"
    clean_obs.write_text((rtk / "07590920.05o").read_text())
    obs = tmp_path / "07590920.05o"
    obs.write_text(_inject_rinex2_pseudorange(clean_obs.read_text(), "G20", 80, 1.0))
    args = ["--nav", rtk / "07590920.05n", "--position", "-3976219.5082,3382372.5671,3652512.9849",
            "--train", 1200, "--window", 10, "--json"]
    clean = _invoke(clean_obs, *args)
    assert clean.exit_code == 0, clean.output
    faulty = _invoke(obs, *args)
    assert faulty.exit_code == 1, faulty.output
    doc = json.loads(faulty.stdout)
    assert set(doc) == KEYS | {"faulty", "untested", "codes", "channel_events", "t0_gps_ns"} and doc["mode"] == "identification"
    assert doc["n_epochs"] == 120 and doc["codes"] == ["C1", "P2"]
    assert doc["state"] == "alarm" and json.loads(clean.stdout)["state"] == "ok"
    # the drag is on both code observables: each is named, alone, after the onset
    assert sorted(f["channel"] for f in doc["faulty"]) == ["G20 C1", "G20 P2"]
    assert all(80 * 30 <= f["t"] <= 90 * 30 for f in doc["faulty"])
    late = [a for a in doc["alarms"] if a["t"] >= 80 * 30]
    assert late and {a["channel"] for a in late} == {"G20 C1", "G20 P2"}
    assert late[0]["t"] <= 90 * 30  # found within ten 30 s epochs of the onset
    assert "G08 C1" in json.loads(clean.stdout)["untested"]  # 36 epochs above the 15 deg mask: fewer than train
    before = {a["channel"] for a in json.loads(clean.stdout)["alarms"] if a["t"] >= 80 * 30}
    assert not before & {"G20 C1", "G20 P2"}


def _drop_rinex2_epochs(text: str, drop: set[int]) -> str:
    """Remove whole epoch records (header line and satellite lines) of a 4-type RINEX 2 obs file."""
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    out = lines[:k]
    epoch = 0
    while k < len(lines):
        nsat = int(lines[k][29:32])
        if lines[k][28] not in "01":
            out += lines[k : k + 1 + nsat]
            k += 1 + nsat
            continue
        extra = (nsat - 1) // 12
        if epoch not in drop:
            out += lines[k : k + 1 + extra + nsat]
        k += 1 + extra + nsat
        epoch += 1
    return "\n".join(out) + "\n"


def test_rinex_with_missing_epochs_counts_them_as_skipped(tmp_path, real_data):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    obs = tmp_path / "gappy.05o"
    obs.write_text(_drop_rinex2_epochs((rtk / "07590920.05o").read_text(), {50, 51, 90}))
    result = _invoke(obs, "--nav", rtk / "07590920.05n", "--position",
                     "-3976219.5082,3382372.5671,3652512.9849", "--train", 1200, "--window", 10, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["n_epochs"] == 120 and doc["n_skipped"] == 3


@pytest.mark.parametrize("position", ["1,2,3", "48.1,11.6,520", "-3976.2195,3382.3726,3652.5130"])
def test_a_position_that_is_not_ecef_metres_on_the_earth_is_refused(tmp_path, real_data, position):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    result = _invoke(rtk / "07590920.05o", "--nav", rtk / "07590920.05n", f"--position={position}",
                     "--train", 1200, "--json")
    assert result.exit_code == 2 and "from the Earth's centre" in result.stderr


STATION_0759 = np.array([-3976219.5082, 3382372.5671, 3652512.9849])


@pytest.mark.parametrize("offset_m", [1_000.0, 10_000.0])
def test_a_position_kilometres_off_makes_integrity_unavailable_not_alarms_on_healthy_satellites(real_data, offset_m):
    # 1 km and 10 km off gave 80 and 51 alarms blaming healthy satellites
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    east = np.array([-np.sin(np.arctan2(STATION_0759[1], STATION_0759[0])), np.cos(np.arctan2(STATION_0759[1], STATION_0759[0])), 0.0])
    pos = STATION_0759 + offset_m * east
    result = _invoke(rtk / "07590920.05o", "--nav", rtk / "07590920.05n", f"--position={','.join(map(str, pos))}",
                     "--train", 1200, "--window", 10, "--json")
    doc = json.loads(result.stdout)
    assert result.exit_code == 3 and doc["state"] == "unavailable", result.output
    assert any("single-point fix" in r for r in doc["unavailable_reasons"])
    assert doc["faulty"] == [] or doc["state"] == "unavailable"


def test_a_navigation_file_of_another_day_tests_nothing_and_says_integrity_unavailable(real_data):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    other_day = real_data / "receivers" / "rinex" / "georinex" / "demo.10n"
    result = _invoke(rtk / "07590920.05o", "--nav", other_day, "--position", ",".join(map(str, STATION_0759)),
                     "--train", 1200, "--window", 10, "--json")
    doc = json.loads(result.stdout)
    assert result.exit_code == 3 and doc["state"] == "unavailable" and doc["n_tested"] == 0, result.output
    assert any("no channel could be tested" in r for r in doc["unavailable_reasons"])
    human = _invoke(rtk / "07590920.05o", "--nav", other_day, "--position", ",".join(map(str, STATION_0759)),
                    "--train", 1200, "--window", 10)
    assert human.exit_code == 3 and "integrity unavailable" in human.stdout and "no alarm" not in human.stdout


def test_a_fault_on_p2_alone_is_named_on_p2(tmp_path, real_data):
    # identification used only C1, so a fault on P2 was invisible
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    text = (rtk / "30400920.05o").read_text()
    obs = tmp_path / "30400920.05o"
    obs.write_text(_inject_rinex2_pseudorange(text, "G11", 60, 1.0, fields=(3,)))
    result = _invoke(obs, "--nav", rtk / "30400920.05n", "--position", _header_position(text), "--train", 1200,
                     "--window", 10, "--json")
    doc = json.loads(result.stdout)
    assert result.exit_code == 1, result.output
    assert [f["channel"] for f in doc["faulty"]] == ["G11 P2"] and doc["faulty"][0]["t"] >= 60 * 30


def _header_position(text: str) -> str:
    line = next(line for line in text.splitlines() if "APPROX POSITION XYZ" in line)
    return ",".join(line[:42].split())


def test_a_rinex_file_whose_last_epoch_is_cut_keeps_the_good_epochs(tmp_path, real_data):
    rtk = real_data / "receivers" / "rinex" / "rtklib"
    text = (rtk / "07590920.05o").read_text()
    cut = tmp_path / "07590920.05o"
    cut.write_text(text[: len(text) - 120])  # a recording stopped in the middle of the last epoch's data
    result = _invoke(cut, "--nav", rtk / "07590920.05n", "--position", ",".join(map(str, STATION_0759)),
                     "--train", 1200, "--window", 10, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["n_epochs"] >= 118 and doc["state"] == "ok"


def test_a_glonass_only_file_says_that_gps_is_missing(tmp_path, real_data):
    from chronofuse.io.rinex import _RINEX2_EPOCH

    rtk = real_data / "receivers" / "rinex" / "rtklib"
    lines, body = [], False
    for line in (rtk / "07590920.05o").read_text().splitlines():
        if body and _RINEX2_EPOCH.match(line):
            line = line[:32] + line[32:68].replace("G", "R") + line[68:]
        body = body or "END OF HEADER" in line
        lines.append(line)
    glo = tmp_path / "glonass.05o"
    glo.write_text("\n".join(lines) + "\n")
    _one_line_error(_invoke(glo, "--nav", rtk / "07590920.05n", "--position", ",".join(map(str, STATION_0759)),
                            "--train", 1200, "--json"), "glonass.05o", "it holds GLONASS", "GPS pseudoranges")


def test_the_command_exit_codes_are_the_library_states():
    from chronofuse.integrity.modes import EXIT_CODES

    assert detect_cli._EXIT_CODES == EXIT_CODES == EXIT


def test_importing_the_detect_command_does_not_import_the_detector_library():
    import subprocess
    import sys

    code = "import sys, chronofuse.cli.detect; print('scipy' in sys.modules, 'chronofuse.integrity.modes' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(__import__("pathlib").Path(detect_cli.__file__).parents[2])})
    assert out.stdout.split() == ["False", "False"]


def test_detect_help_imports_no_numpy():
    # `detect --help` under 0.5 s; numpy (through cli.common and report.jsonio, 0.12 s of the
    # import time measured with -X importtime) is what the command module itself pulled in before (typer
    # renders its help with rich's tables itself)
    import subprocess
    import sys

    code = ("import sys; sys.argv = ['chronofuse', 'detect', '--help']\n"
            "from chronofuse.cli.main import main\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "print('numpy' in sys.modules, 'chronofuse.cli.common' in sys.modules, file=sys.stderr)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(__import__("pathlib").Path(detect_cli.__file__).parents[2])})
    assert "--train" in out.stdout
    assert out.stderr.split()[-2:] == ["False", "False"]
