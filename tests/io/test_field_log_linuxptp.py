"""linuxptp logs (ptp4l, phc2sys, ts2phc) from real captures: values as the programs printed them, the servo
states, and the whole-second errors a G.8272 analyser of the same files rejects."""

from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.field_logs import pick_series, read_log, series_clock_bias, series_record
from chronofuse.io.formats import sniff_format
from chronofuse.io.linuxptp import read_linuxptp
from chronofuse.validation import InputDataError

DATA = Path(__file__).parents[1] / "data" / "logs" / "linuxptp"
PTP4L = DATA / "ptp411.log.gz"  # ptp4l from start-up: s0, s1, then s2 with port events
REJECT = DATA / "ts2phc-reject.log.gz"  # vse-sync-test's example of a DPLL-to-PHC time error it rejects
SHORT = DATA / "ts2phc-short.log.gz"  # phc2sys and ts2phc interleaved, with extts lines


@pytest.mark.parametrize("path", [PTP4L, REJECT, SHORT])
def test_each_linuxptp_capture_is_told_apart_from_its_content(path):
    assert sniff_format(path) == "linuxptp"


def test_ptp4l_samples_carry_the_printed_offset_frequency_delay_and_servo_state():
    (s,) = read_log(PTP4L)
    assert s.clock == "ptp4l" and s.n == 94 and s.time_scale == "monotonic"
    # line 10: "ptp4l[13875.234]: master offset   -1604514 s2 freq  -89987 path delay   -562981"
    k = int(np.flatnonzero(s.lines == 10)[0])
    assert s.t_ns[k] == 13875_234_000_000
    assert s.columns["offset_s"][k] == pytest.approx(-1604514e-9, rel=1e-12)
    assert s.columns["freq"][k] == pytest.approx(-89987e-9, rel=1e-12)
    assert s.columns["delay_s"][k] == pytest.approx(-562981e-9, rel=1e-12)
    assert s.columns["offset_s"][-1] == pytest.approx(103e-9)  # the file's last line
    assert list(s.ok[:3]) == [False, False, True]  # s0 (unlocked), s1 (jump), s2 (locked)


def test_port_transitions_and_the_best_master_are_events_with_their_lines():
    (s,) = read_log(PTP4L)
    texts = dict(s.events)
    assert texts[6] == "selected best master clock 641c10.fffe.f12579"
    assert "UNCALIBRATED to SLAVE on MASTER_CLOCK_SELECTED" in texts[11]


def test_phc2sys_and_ts2phc_interleaved_are_separate_clocks():
    by = {s.clock: s for s in read_linuxptp(SHORT)}
    assert set(by) == {"phc2sys CLOCK_REALTIME phc [ptp4l.0.config]", "ts2phc ens7f1 extts [ts2phc.0.config]",
                       "ts2phc ens7f1 [ts2phc.0.config]"}
    phc = by["phc2sys CLOCK_REALTIME phc [ptp4l.0.config]"]
    assert phc.n == 204 and phc.columns["offset_s"][0] == pytest.approx(7e-9)
    assert phc.columns["delay_s"][0] == pytest.approx(500e-9)
    # phc2sys sleeps 1/16 s between updates and its work adds to it: steps print as 62 or 63 ms, the grid is
    # their mean (62.6 ms), on which every sample finds its own slot within 1.3 ms
    rec = series_record(phc)
    assert 1 / rec.rate_hz == pytest.approx(np.diff(phc.t_ns).mean() / 1e9, rel=1e-5)
    assert rec.n_gaps == 0 and rec.jitter_max_s < 2e-3


def test_the_three_whole_second_errors_of_the_rejected_capture_are_found_at_their_lines():
    (s,) = read_log(REJECT)
    big = np.flatnonzero(np.abs(s.columns["offset_s"]) > 0.5)
    starts = big[np.r_[True, np.diff(big) > 1]]
    assert list(s.lines[starts]) == [4650, 4997, 5179]
    np.testing.assert_array_equal(s.columns["offset_s"][starts], 1.0)
    # each follows a silence of ts2phc (12, 14 and 20 s without a line), the log's only three
    steps = np.diff(s.t_ns) / 1e9
    assert list(steps[starts - 1]) == [12.0, 14.0, 20.0] and (steps > 1.5).sum() == 3
    rec = series_record(s)
    assert rec.n_gaps == 43  # 11 + 13 + 19 missing seconds
    # the analyser's criterion (PRTC-A, 10 % of 100 ns after a 300 s transient) must reject this file ...
    settled = (s.t_ns - s.t_ns[0]) > 300e9
    assert np.abs(s.columns["offset_s"][settled]).max() > 10e-9
    # ... and not for want of lock: every sample is s2
    assert s.ok.all()


def test_detect_reads_the_ts2phc_offset_on_its_one_second_grid():
    (s,) = read_log(REJECT)
    cb = series_clock_bias(s)
    bias = cb.columns["clock_bias_s"]
    assert cb.interval_ns == 1_000_000_000 and bias.size == s.n + 43 and cb.time_scale == "file"
    assert np.nanmax(bias) == 1.0 and cb.valid.all() and cb.units["clock_bias_s"] == "s"
    # each epoch knows its log line; the 43 filled-in seconds know none
    assert cb.provenance.where(0).endswith("ts2phc-reject.log.gz:1") and (cb.provenance.position == -1).sum() == 43


def test_a_journal_prefixed_line_and_a_summary_line_are_read(tmp_path):
    path = tmp_path / "journal.log"
    path.write_text(
        "Feb 15 20:04:04 host ptp4l[383]: [24.634] master offset -12 s2 freq -1843 path delay 529\n"
        "Feb 15 20:04:05 host ptp4l[383]: [25.634] master offset 4 s2 freq -1836 path delay 530\n"
        "ptp4l[26.000]: rms    3 max    4 freq  -1840 +/-   5 delay   530 +/-   1\n")
    by = {s.clock: s for s in read_log(path)}
    assert by["ptp4l"].t_ns.tolist() == [24_634_000_000, 25_634_000_000]  # the bracket after the pid
    assert by["ptp4l"].columns["offset_s"].tolist() == pytest.approx([-12e-9, 4e-9])
    assert by["ptp4l summary"].columns["rms_s"][0] == pytest.approx(3e-9)


def test_a_clock_name_that_matches_none_is_refused_naming_the_clocks():
    with pytest.raises(InputDataError, match="ptp4l"):
        pick_series(read_log(SHORT), "eth9", str(SHORT))


def test_a_backward_time_tag_names_its_line(tmp_path):
    path = tmp_path / "back.log"
    path.write_text("ptp4l[10.000]: master offset 1 s2 freq 0 path delay 5\n"
                    "ptp4l[9.000]: master offset 1 s2 freq 0 path delay 5\n")
    with pytest.raises(InputDataError, match=r"back\.log:2: "):
        read_log(path)
