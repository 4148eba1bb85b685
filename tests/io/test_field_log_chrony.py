"""chrony's tracking, statistics and refclocks logs, written by a real chronyd (4.3, Debian) fed through its
SOCK reference clock, checked against what chronyc printed from the same daemon at the end of the run."""

import gzip
import re
from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.field_logs import read_log, series_record
from chronofuse.io.formats import sniff_format
from chronofuse.validation import InputDataError

DATA = Path(__file__).parents[1] / "data" / "logs" / "chrony"


def _chronyc(name: str) -> str:
    return (DATA / f"chronyc-{name}.txt").read_text()


@pytest.mark.parametrize("log", ["tracking", "statistics", "refclocks"])
def test_each_chrony_log_is_told_apart_from_its_content(log):
    assert sniff_format(DATA / f"{log}.log.gz") == "chrony"


def test_the_last_tracking_row_is_what_chronyc_tracking_printed():
    (s,) = read_log(DATA / "tracking.log.gz")
    text = _chronyc("tracking")
    last_offset = float(re.search(r"Last offset\s+:\s+(\S+) seconds", text).group(1))
    freq_ppm, side = re.search(r"Frequency\s+:\s+(\S+) ppm (fast|slow)", text).groups()
    skew_ppm = float(re.search(r"Skew\s+:\s+(\S+) ppm", text).group(1))
    assert s.columns["offset_s"][-1] == pytest.approx(last_offset, abs=5e-10)  # chronyc prints 9 decimals
    assert side == "fast" and s.columns["freq"][-1] == pytest.approx(float(freq_ppm) * 1e-6, abs=5e-10)
    assert s.columns["freq_bound"][-1] == pytest.approx(skew_ppm * 1e-6, abs=5e-10)
    # the feed simulated a clock 3 ppm fast: the frequency column says so, and with the right sign
    assert s.columns["freq"][-10:] == pytest.approx(3e-6, abs=2e-9)


def test_the_tracking_series_is_one_clock_whose_reference_changes_are_events():
    (s,) = read_log(DATA / "tracking.log.gz")
    assert [text for _, text in s.events] == ["reference 0.0.0.0", "reference GPS"]
    # chronyd's first row (no reference yet, leap status "?") measures nothing: not a sample
    assert s.n == 48 and s.lines[0] == 5 and s.ok.all()
    assert any("1 rows without a reference" in note for note in s.notes)


def test_the_statistics_log_updates_at_irregular_intervals_and_is_refused_as_a_record_naming_the_line():
    (s,) = read_log(DATA / "statistics.log.gz")
    steps = np.diff(s.t_ns) / 1e9
    assert steps.min() == 2 and steps.max() == 6  # chronyd updates a source when its samples say so
    with pytest.raises(InputDataError, match=r"statistics\.log\.gz:\d+: GPS: time step"):
        series_record(s)


def test_the_last_statistics_row_is_what_chronyc_sourcestats_printed():
    (s,) = read_log(DATA / "statistics.log.gz")
    row = _chronyc("sourcestats").splitlines()[-1].split()
    name, np_, nr, std = row[0], int(row[1]), int(row[2]), row[-1]
    assert s.clock == name
    assert s.columns["samples"][-1] == np_ and s.columns["runs"][-1] == nr
    assert s.columns["std_dev_s"][-1] == pytest.approx(float(std.rstrip("ns")) * 1e-9, abs=0.5e-9)


def test_the_filtered_refclock_offset_has_the_sign_chronyc_sources_shows():
    by = {s.clock: s for s in read_log(DATA / "refclocks.log.gz")}
    assert set(by) == {"GPS", "GPS filtered"}
    sample = re.search(r"\[\s*([+-]\d+)ns\]\s+\+/-\s+(\d+)ns", _chronyc("sources"))
    measured_ns, err_ns = int(sample.group(1)), int(sample.group(2))
    filtered = by["GPS filtered"]
    # chronyc: the last measured offset, positive when the local clock is fast; the log's cooked offset is
    # the other way round, and the reader's offset_s is local minus reference like chronyc
    assert filtered.columns["offset_s"][-1] * 1e9 == pytest.approx(measured_ns, abs=0.5)
    assert filtered.columns["dispersion_s"][-1] * 1e9 == pytest.approx(err_ns, abs=1)


def test_the_raw_refclock_samples_are_the_offsets_the_feed_sent():
    raw = {s.clock: s for s in read_log(DATA / "refclocks.log.gz")}["GPS"]
    # the feed sent reference minus system = -(250 us + 3 ppm * t + white PM): the raw column, as chrony logs it
    assert raw.columns["raw_offset_s"][0] == pytest.approx(-2.5e-4, abs=2e-6)
    slope = np.polyfit((raw.t_ns - raw.t_ns[0]) / 1e9, raw.columns["raw_offset_s"], 1)[0]
    assert slope == pytest.approx(-3e-6, rel=1e-3)
    # the feed's first sample came 0.735 s before its 1 s schedule began: off the grid, refused naming it
    with pytest.raises(InputDataError, match=r"refclocks\.log\.gz:5: .*0\.735"):
        series_record(raw)


def test_a_line_of_another_log_layout_in_a_tracking_log_names_its_line(tmp_path):
    text = gzip.decompress((DATA / "tracking.log.gz").read_bytes()).decode().splitlines()
    text.insert(6, "2026-12-02 02:50:20 GPS 1 2 3")
    path = tmp_path / "tracking.log"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(InputDataError, match=r"tracking\.log:7: "):
        read_log(path)


def test_a_tracking_log_without_the_columns_chrony_35_added_is_read_with_them_missing(tmp_path):
    # a row that ends at "Rem. corr." (no root delay, root dispersion or max error): older chronyd wrote fewer
    rows = [line for line in gzip.decompress((DATA / "tracking.log.gz").read_bytes()).decode().splitlines()
            if line[:2] == "20" and " GPS " in line]
    path = tmp_path / "tracking-old.log"
    path.write_text("\n".join(" ".join(row.split()[:11]) for row in rows) + "\n")
    assert sniff_format(path) == "chrony"
    (s,) = read_log(path)
    (full,) = read_log(DATA / "tracking.log.gz")
    np.testing.assert_array_equal(s.columns["offset_s"], full.columns["offset_s"])
    assert np.isnan(s.columns["max_error_s"]).all()
