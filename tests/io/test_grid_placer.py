"""The grid a stream is placed on: the interval learnt from the first steps, jitter tolerated and measured,
missing slots become gaps, errors name the line; the same epochs whatever the chunks (the batch reader and a
live stream share it)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chronofuse.io.grid import GridPlacer, snap_interval_ns
from chronofuse.record import EpochRecord
from chronofuse.validation import InputDataError


def _raw(t_ns, values=None, start_line=2):
    t = np.asarray(t_ns, dtype=np.int64)
    v = np.arange(t.size, dtype=float) if values is None else values
    return EpochRecord.from_arrays(t, {"clock_bias_s": v}, {"clock_bias_s": "s"}, source="b.csv",
                                   position=start_line + np.arange(t.size), position_unit="line", time_scale="file")


def _place(record, chunks=None, **kw):
    placer = GridPlacer(**kw)
    parts = [record] if chunks is None else [record[a:b] for a, b in zip([0, *chunks], [*chunks, record.n_epochs])]
    return EpochRecord.concat([*(placer.push(p) for p in parts), placer.close()])


def test_the_interval_is_the_lower_median_of_the_first_steps_snapped_and_gaps_are_filled():
    t = 1_700_000_000_123_456_789 + np.array([0, 1, 2, 3, 5, 6, 7, 8, 9, 10, 11, 12]) * 10**9
    grid = _place(_raw(t))
    assert grid.interval_ns == 10**9 and grid.n_epochs == 13 and grid.info["n_gaps"] == 1
    assert np.isnan(grid.columns["clock_bias_s"][4]) and grid.provenance.position[4] == -1
    np.testing.assert_array_equal(grid.t_ns, t[0] + np.arange(13) * 10**9)
    assert snap_interval_ns(999_999_987, None) == 1_000_000_000 and snap_interval_ns(999, 1) == 999
    assert snap_interval_ns(1_001_000_000, 1_000_000) == 1_001_000_000


def test_jittered_tags_go_to_their_slots_and_the_jitter_is_reported():
    offsets_ms = np.array([0, 1, -1, 0, 1, 0, 0, -1, 0, 1, 0])
    t = (np.arange(11) * 1000 + offsets_ms) * 10**6
    grid = _place(_raw(t), resolution_ns=10**6)
    assert grid.interval_ns == 10**9 and grid.info["jitter_max_s"] == pytest.approx(1e-3)
    np.testing.assert_allclose(grid.columns["tag_offset_s"], offsets_ms * 1e-3)


def test_a_step_off_the_grid_and_time_going_back_name_their_lines():
    t = np.arange(12) * 10**9
    bad = t.copy()
    bad[10] += 4 * 10**8
    with pytest.raises(InputDataError, match=r"b.csv:12: time step 1.4 s is not a whole number of 1 s"):
        _place(_raw(bad))
    placer = GridPlacer()
    placer.push(_raw(t[:6]))
    with pytest.raises(InputDataError, match=r"b.csv:6: time is not increasing"):
        placer.push(_raw(t[3:9], start_line=6))  # a chunk that goes back to an earlier epoch
    with pytest.raises(InputDataError, match="one epoch and no sampling rate"):
        _place(_raw([5]))
    assert _place(_raw([5]), interval_ns=10**9).n_epochs == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(1, 4), min_size=2, max_size=60), st.lists(st.integers(1, 59), max_size=8),
       st.integers(-2**40, 2**40), st.booleans())
def test_the_epochs_placed_are_the_same_whatever_the_chunks(steps, cuts, t0, given_interval):
    t = t0 + np.cumsum([0, *([1] * 8), *steps]) * 250_000_000  # the first steps set the interval
    record = _raw(t)
    interval = 250_000_000 if given_interval else None
    whole = _place(record, interval_ns=interval)
    cuts = sorted({c for c in cuts if c < record.n_epochs})
    split = _place(record, cuts, interval_ns=interval)
    np.testing.assert_array_equal(split.t_ns, whole.t_ns)
    np.testing.assert_array_equal(split.columns["clock_bias_s"], whole.columns["clock_bias_s"])
    assert split.interval_ns == whole.interval_ns and split.info["n_gaps"] == whole.info["n_gaps"]
