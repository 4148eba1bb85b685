"""The numba time-column kernels against their readable twins, and both reading paths (whole file and
batch by batch) against each other."""

import gzip
from fractions import Fraction
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from chronofuse.io import records
from chronofuse.io.columns import decimal_text_to_ns
from chronofuse.io.kernels_time import FRACTION_DIGITS, parse_decimal_ns
from chronofuse.io.records import read_record


@pytest.mark.parametrize("per_unit", [1_000_000_000, 1_000_000, 1, 86_400 * 1_000_000_000])
def test_decimal_tags_parse_in_numba_exactly_as_the_twin(per_unit):
    texts = ["0", "1700000000.123456789", " 12.5 ", "-3.25", "+7", ".5", "59999.000011574074074074", "42.",
             "1.00000000000000000009", "00012"]
    texts = [t for t in texts if abs(float(t)) * per_unit < 9e18]  # what fits in int64 ns in this unit
    arr = pa.array(texts)
    expected, bad = decimal_text_to_ns(arr, per_unit)
    assert bad == -1
    ratio = Fraction(per_unit) / 10**FRACTION_DIGITS
    out = np.empty(len(texts), dtype=np.int64)
    offsets = np.frombuffer(arr.buffers()[1], dtype=np.int32)
    data = np.frombuffer(arr.buffers()[2], dtype=np.uint8)
    assert parse_decimal_ns(data, offsets, 0, len(texts), per_unit, ratio.numerator, ratio.denominator, out) == -1
    np.testing.assert_array_equal(out, expected)
    for text in ("1e3", "abc", "", "1.2.3", "--1"):
        one = pa.array([text])
        o = np.frombuffer(one.buffers()[1], dtype=np.int32)
        d = np.frombuffer(one.buffers()[2], dtype=np.uint8) if one.buffers()[2] is not None else np.zeros(0, np.uint8)
        assert parse_decimal_ns(d, o, 0, 1, per_unit, ratio.numerator, ratio.denominator, np.empty(1, np.int64)) == 0


def test_the_numba_grid_equals_its_numpy_twin_with_jitter_and_gaps(tmp_path):
    rng = np.random.default_rng(2)
    slots = np.cumsum(rng.choice([1, 1, 1, 2, 5], size=50_000))
    t_ns = 1_700_000_000 * 10**9 + slots * 10_000_000 + rng.integers(-200_000, 200_000, slots.size)
    layout = records.sniff(_write(tmp_path, t_ns))
    fast = records._time_grid(t_ns, None, tmp_path / "t.csv", layout)
    twin = records._time_grid_numpy(t_ns, None, tmp_path / "t.csv", layout)
    np.testing.assert_array_equal(fast.slots, twin.slots - twin.slots[0])
    assert fast.interval_ns == pytest.approx(twin.interval_ns, rel=1e-12)
    assert fast.start_ns == pytest.approx(twin.start_ns, abs=1e-3)
    assert fast.jitter_rms_s == pytest.approx(twin.jitter_rms_s, rel=1e-9)
    assert fast.jitter_max_s == pytest.approx(twin.jitter_max_s, rel=1e-9)


def _write(tmp_path: Path, t_ns: np.ndarray) -> Path:
    path = tmp_path / "t.csv"
    path.write_text("".join(f"{t // 10**9}.{t % 10**9:09d},1e-9\n" for t in t_ns[:300]))
    return path


def test_a_gzipped_time_column_read_batch_by_batch_equals_the_plain_file_read_at_once(tmp_path):
    rng = np.random.default_rng(3)
    n = 200_000
    t = [f"{1700000000 + k // 10}.{k % 10}" for k in range(n) if k % 997 != 5]  # 10 Hz, some samples missing
    x = rng.standard_normal(len(t)) * 1e-9
    text = "".join(f"{a},{b!r}\n" for a, b in zip(t, x.tolist()))
    plain = tmp_path / "plain.csv"
    plain.write_text(text)
    packed = tmp_path / "packed.csv.gz"
    with gzip.open(packed, "wt") as fh:
        fh.write(text)
    a, b = read_record(plain), read_record(packed)
    assert a.rate_hz == b.rate_hz == 10.0 and a.n_gaps == b.n_gaps > 0
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.t_ns, b.t_ns)
