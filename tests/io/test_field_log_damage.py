"""Damaged field logs: whatever is cut, doubled or overwritten in a real capture, a reader either reads it
or says what is wrong naming the file (InputDataError); it never fails with another exception."""

import gzip
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from chronofuse.io.field_logs import read_log, series_record
from chronofuse.validation import InputDataError

LOGS = Path(__file__).parents[1] / "data" / "logs"
CAPTURES = {
    "linuxptp": LOGS / "linuxptp" / "ts2phc-short.log.gz",
    "chrony": LOGS / "chrony" / "tracking.log.gz",
    "rtklib-pos": LOGS / "rtklib" / "bor1-spp.pos.gz",
    "rtklib-stat": LOGS / "rtklib" / "bor1-spp.pos.stat.gz",
    "gpsd-json": LOGS / "gpsd" / "gpsd-tsip-watch.json.gz",
    "tsip": LOGS.parent / "receivers" / "gpsd" / "trimble-ressmt360-dr.log",
}


def _raw(path: Path) -> bytes:
    data = path.read_bytes()
    return gzip.decompress(data) if data[:2] == b"\x1f\x8b" else data


damage = st.lists(st.tuples(st.sampled_from(["cut", "double", "overwrite", "truncate"]), st.floats(0, 1),
                            st.integers(1, 40), st.binary(min_size=1, max_size=12)), min_size=1, max_size=4)


def _damaged(data: bytes, edits) -> bytes:
    for op, where, length, junk in edits:
        i = int(where * max(len(data) - 1, 0))
        if op == "cut":
            data = data[:i] + data[i + length:]
        elif op == "double":
            data = data[:i + length] + data[i:]
        elif op == "overwrite":
            data = data[:i] + junk + data[i + len(junk):]
        else:
            data = data[:max(i, 1)]
    return data


@pytest.mark.parametrize("fmt", sorted(CAPTURES))
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=damage)
def test_a_damaged_capture_is_read_or_refused_naming_the_file(fmt, edits, tmp_path):
    path = tmp_path / f"damaged-{fmt}"
    path.write_bytes(_damaged(_raw(CAPTURES[fmt]), edits))
    try:
        series = read_log(path, fmt)
    except InputDataError as exc:
        assert str(path) in str(exc)
        return
    for s in series:
        try:
            series_record(s, kind=None if s.phase else "freq" if s.freq else None)
        except InputDataError as exc:
            assert str(path) in str(exc)
