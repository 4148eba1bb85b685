"""Navigation that serves only part of the observations, or none of a system asked for, is analysed with a
warning naming it, never silently (NYA1, tests/data/rinex/igs: its GPS and Galileo files cut to their late hours)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from chronofuse.experiments.real_positioning import position_from_files
from chronofuse.io.rinex_text import rinex_bytes


def _records_from(nav_path, first_hour: int, out) -> None:
    """The RINEX 3 navigation file ``nav_path`` (8-line records) keeping the records of the file's own day (the
    commonest toc day: daily files carry a few of the day before) whose toc hour is ``first_hour`` or later."""
    lines = rinex_bytes(nav_path).decode("ascii").splitlines()
    body = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    days = [lines[i][12:14] for i in range(body, len(lines), 8)]
    day = max(set(days), key=days.count)
    kept = lines[:body]
    for i in range(body, len(lines), 8):
        if lines[i][12:14] == day and int(lines[i][15:17]) >= first_hour:
            kept.extend(lines[i:i + 8])
    out.write_text("\n".join(kept) + "\n")


def _messages(record) -> list[str]:
    return [str(w.message) for w in record]


def test_navigation_that_covers_under_half_the_day_is_warned_with_the_span_fixed(igs_stations, tmp_path):
    s = igs_stations["NYA1"]
    gn = tmp_path / "gn_from_16h.rnx"
    _records_from(next(p for p in s.nav_paths if "_GN" in p.name), 16, gn)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        fixes, summary = position_from_files(s.obs_path, [gn], ("G",))
    assert summary["fixes"] < 0.5 * summary["epochs"]
    assert any("epochs have a fix" in m and str(gn) in m for m in _messages(record)), _messages(record)


def test_a_system_whose_records_serve_no_epoch_is_warned_and_the_whole_navigation_is_not(igs_stations, tmp_path):
    s = igs_stations["NYA1"]
    gn = next(p for p in s.nav_paths if "_GN" in p.name)
    en = tmp_path / "en_from_20h.rnx"
    _records_from(next(p for p in s.nav_paths if "_EN" in p.name), 20, en)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        position_from_files(s.obs_path, [gn, en], ("G", "E"), end_s=8 * 3600.0)
    messages = _messages(record)
    assert any("gal gave no satellite to any fix" in m for m in messages), messages
    assert not any("gps gave no satellite" in m or "epochs have a fix" in m for m in messages), messages
    # the negative control: the whole files, both systems used, no warning of either kind
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        fixes, _ = position_from_files(s.obs_path, [gn, next(p for p in s.nav_paths if "_EN" in p.name)],
                                       ("G", "E"), end_s=8 * 3600.0)
    assert not any("gave no satellite" in m or "epochs have a fix" in m for m in _messages(record))
    assert np.isfinite(fixes.residual_m[:, [k for k, n in enumerate(fixes.satellites) if n[0] == "E"]]).any()
