"""stability and detect read the field's logs: the ts2phc capture vse-sync-test rejects fails PRTC-A and
alarms at its whole-second errors; the same capture cut before them passes and raises no alarm."""

import gzip
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app

LOGS = Path(__file__).parents[1] / "data" / "logs"
REJECT = LOGS / "linuxptp" / "ts2phc-reject.log.gz"
runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """The rejected capture's first 4640 lines: ts2phc locked, before its first silence and whole-second error."""
    path = tmp_path_factory.mktemp("logs") / "ts2phc-clean.log"
    lines = gzip.decompress(REJECT.read_bytes()).decode().splitlines(keepends=True)
    path.write_text("".join(lines[:4640]))
    return path


def _mask(result) -> dict:
    assert result.exit_code == 0, result.output
    return json.loads(result.output)["masks"][0]


def test_the_rejected_ts2phc_log_fails_prtc_a_on_its_one_second_time_error():
    verdict = _mask(invoke("stability", REJECT, "--dev", "tdev", "--mask", "prtc-a", "--json"))
    assert verdict["passed"] is False
    assert verdict["time_error"]["max_abs_te"] == pytest.approx(1.0)


def test_the_same_log_before_its_errors_passes_prtc_a(clean):
    verdict = _mask(invoke("stability", clean, "--dev", "tdev", "--mask", "prtc-a", "--json"))
    assert verdict["passed"] is True
    assert verdict["time_error"]["max_abs_te"] <= 1e-9


def test_detect_alarms_at_the_first_whole_second_error_and_not_before():
    result = invoke("detect", REJECT, "--train", 600, "--json")
    assert result.exit_code == 1, result.output  # detect's status for a record in alarm
    doc = json.loads(result.output)
    assert doc["state"] == "alarm"
    first = doc["alarms"][0]["t"]
    assert 852564.839 <= first <= 852567.839  # the error's own line, 4650, is stamped 852564.839
    assert any(e["kind"] == "clock reset" and e["size_s"] == pytest.approx(-1.0) for e in doc["clock_events"])


def test_detect_raises_no_alarm_on_the_log_before_its_errors(clean):
    result = invoke("detect", clean, "--train", 600, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["state"] == "ok" and doc["n_alarms"] == 0


def test_station_picks_a_clock_of_the_log_and_one_that_is_none_exits_2_naming_the_clocks():
    short = LOGS / "linuxptp" / "ts2phc-short.log.gz"
    ok = invoke("stability", short, "--station", "phc2sys", "--dev", "adev", "--json")
    assert ok.exit_code == 0, ok.output
    assert json.loads(ok.output)["n"] >= 204
    bad = invoke("stability", short, "--station", "eth9", "--dev", "adev")
    assert bad.exit_code == 2 and "phc2sys CLOCK_REALTIME phc" in bad.output
    assert "--station 'eth9' is none of this log's clocks" in " ".join(bad.output.split())  # the option, not {clock}
    column = invoke("stability", short, "--column", "nope", "--dev", "adev")
    assert column.exit_code == 2 and "--column 'nope': not a column of phc2sys" in " ".join(column.output.split())


def test_a_log_of_several_clocks_read_without_station_warns_naming_the_option_that_picks_another():
    result = invoke("stability", LOGS / "linuxptp" / "ts2phc-short.log.gz", "--dev", "adev")
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "3 clocks in this log" in text and "is read (--station picks another)" in text


def test_a_chrony_tracking_log_feeds_stability_as_frequency():
    result = invoke("stability", LOGS / "chrony" / "tracking.log.gz", "--kind", "freq", "--dev", "adev", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["kind"] == "freq" and doc["rate"] == pytest.approx(0.25, rel=0.01)  # 4 s updates, whole-second stamps


def test_the_gnssdo_reference_reader_takes_a_ts2phc_log_and_refuses_one_with_gaps(clean):
    from chronofuse.io.pps_reference import read_pps_reference
    from chronofuse.validation import InputDataError

    phase = read_pps_reference(clean)
    assert phase.size == 4640 and abs(phase).max() <= 1e-9  # every one of the 4640 lines is a 1 s sample
    with pytest.raises(InputDataError, match="gap in the reference record .43 missing samples"):
        read_pps_reference(REJECT)


def test_inspect_lists_a_logs_clocks_and_exports_the_one_asked_for(tmp_path):
    short = LOGS / "linuxptp" / "ts2phc-short.log.gz"
    out = tmp_path / "phc2sys.csv"
    result = invoke("inspect", short, "--station", "phc2sys", "--out", out, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["format"] == "linuxptp" and len(doc["clocks"]) == 3
    assert doc["export"] == {"file": str(out), "clock": "phc2sys CLOCK_REALTIME phc [ptp4l.0.config]", "rows": 204}
    rows = out.read_text().splitlines()
    assert rows[0] == "t_ns,offset_s,freq,delay_s,ok,line" and rows[1].startswith("680988761000000,7")
    tagged = tmp_path / "tagged.log"
    tagged.write_text("ptp4l[10.000]: [a] master offset 1 s2 freq 0 path delay 5\n"
                      "ptp4l[11.000]: [a] master offset 2 s2 freq 0 path delay 5\n")
    human = invoke("inspect", tagged)
    assert human.exit_code == 0 and "ptp4l [a]" in human.output  # a tag in a clock's name is printed, not taken for markup


def test_inspect_reads_a_tsip_capture_without_timing_packets_as_a_recording():
    result = invoke("inspect", LOGS.parent / "receivers" / "gpsd" / "trimble-lassen_iq.log", "--json")
    assert result.exit_code == 0, result.output
    assert "clocks" not in json.loads(result.output)


def test_a_field_log_on_standard_input_is_refused_naming_the_file_route():
    text = gzip.decompress((LOGS / "linuxptp" / "ptp411.log.gz").read_bytes()).decode()
    result = runner.invoke(app, ["detect", "-", "--train", "30"], input=text)
    assert result.exit_code == 2
    assert "a linuxptp log is read from a file (detect FILE), not from a stream" in result.output
