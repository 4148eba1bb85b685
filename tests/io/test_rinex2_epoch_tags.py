"""RINEX 2 observation epochs are absolute GPS-time integer ns read from the file's own epoch lines.

georinex keeps RINEX 2 epochs as ``datetime64[ms]`` after reading the seconds through a float: RTKLIB's
07590920.05o line `` 05  4  2  0 21 30.0020000`` came back as 00:21:30.001. The readers replace its times by
the epoch lines' digits; these tests check them against the lines, parsed here with integers only.
"""

from __future__ import annotations

import json
from datetime import datetime

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli
from chronofuse.io.rinex import read_gps_observations
from chronofuse.io.rinex_obs import exact_rinex2_times, read_any_observations, rinex2_epoch_tags_ns
from chronofuse.validation import InputDataError

GPS_EPOCH = datetime(1980, 1, 6)
POSITION_0759 = "-3976219.5082,3382372.5671,3652512.9849"
app = typer.Typer()
detect_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding only the command under test."""


def _line_ns(line: str) -> int:
    """GPS ns of a RINEX 2 epoch line, from its digits (no float): 2005 has no leap second to mind on GPS time."""
    yy, mo, d, h, mi = (int(line[k:k + 3]) for k in (0, 3, 6, 9, 12))
    whole, frac = line[15:26].strip().split(".")
    day = datetime(2000 + yy, mo, d, h, mi) - GPS_EPOCH
    return (day.days * 86400 + day.seconds + int(whole)) * 10**9 + int(frac.ljust(9, "0"))


def _epoch_lines(text: str) -> list[str]:
    body = text.split("END OF HEADER", 1)[1].splitlines()[1:]
    return [ln for ln in body if len(ln) > 32 and ln[28] in "01" and ln[26:28] == "  " and ln[18] == "."]


@pytest.fixture(scope="module")
def rtk(real_data):
    return real_data / "receivers" / "rinex" / "rtklib"


def test_the_first_epoch_of_0759_is_2005_april_2_midnight_gps_in_absolute_ns(rtk):
    obs = read_any_observations(rtk / "07590920.05o")
    assert obs.gps_ns.dtype == np.int64
    assert _epoch_lines((rtk / "07590920.05o").read_text())[0].startswith(" 05  4  2  0  0  0.0000000")
    assert int(obs.gps_ns[0]) == 796_435_200 * 10**9 == _line_ns(" 05  4  2  0  0  0.0000000")


@pytest.mark.parametrize("station", ["07590920", "30400920"])
def test_both_rinex2_readers_give_every_epoch_line_to_the_nanosecond(rtk, station):
    path = rtk / f"{station}.05o"
    want = np.array([_line_ns(ln) for ln in _epoch_lines(path.read_text())], dtype=np.int64)
    np.testing.assert_array_equal(read_any_observations(path).gps_ns, want)
    np.testing.assert_array_equal(read_gps_observations(path).gps_ns, want)
    np.testing.assert_array_equal(rinex2_epoch_tags_ns(path.read_bytes().splitlines()), want)
    if station == "07590920":  # the millisecond georinex loses: 00:21:30.0020000, epoch 44
        assert int(want[43]) - int(want[0]) == 1_290_002_000_000


def test_an_odd_nanosecond_tag_survives_where_georinex_truncates_it(tmp_path, rtk):
    text = (rtk / "07590920.05o").read_text()
    odd = tmp_path / "odd.05o"
    odd.write_text(text.replace(" 05  4  2  0 21 30.0020000", " 05  4  2  0 21 30.0029997", 1))
    obs = read_any_observations(odd)
    assert int(obs.gps_ns[43]) - int(obs.gps_ns[0]) == 1_290_002_999_700
    assert int(read_gps_observations(odd).gps_ns[43]) == int(obs.gps_ns[43])


def test_a_georinex_time_on_no_epoch_line_is_refused_naming_the_file(rtk):
    lines = (rtk / "07590920.05o").read_bytes().splitlines()
    tags = rinex2_epoch_tags_ns(lines)
    np.testing.assert_array_equal(exact_rinex2_times(tags - 999_000, lines, "x.05o"), tags)
    with pytest.raises(InputDataError, match=r"x\.05o: epoch 2 .* on no readable RINEX 2 epoch line"):
        exact_rinex2_times(np.array([tags[0], tags[1] + 1], dtype=np.int64), lines, "x.05o")
    with pytest.raises(InputDataError, match="epoch 1"):
        exact_rinex2_times(tags[:1] - 2_000_000, lines, "x.05o")


def test_identification_on_rinex2_reports_absolute_gps_ns_like_rinex3(rtk):
    result = CliRunner().invoke(app, ["detect", str(rtk / "07590920.05o"), "--nav", str(rtk / "07590920.05n"),
                                      f"--position={POSITION_0759}", "--train", "1200", "--window", "10", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    first = _line_ns(" 05  4  2  0  0  0.0000000")
    assert doc["state"] == "ok" and doc["t0_gps_ns"] == first
    assert doc["unavailable"][0] == {"from_ns": first, "to_ns": first + 39 * 30 * 10**9, "reason": "training"}


def test_a_blank_inside_the_seconds_is_read_as_georinex_reads_it_and_an_unreadable_line_left_to_georinex(real_data):
    path = real_data / "receivers" / "rinex" / "georinex" / "badtime.10o"  # " 0 .0000000", then a 60 s line
    obs = read_gps_observations(path)
    first = datetime(2010, 3, 5) - GPS_EPOCH
    assert obs.gps_ns.tolist() == [first.days * 86400 * 10**9] and obs.n_unreadable_epochs == 1
