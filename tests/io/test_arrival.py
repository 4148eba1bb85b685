"""Epochs out of time order: the bounded reorder buffer (chronofuse.io.arrival) against its definition, and the
batch reader and the live decoder giving the same epochs from the same bytes, however the bytes are split.

Oracle of the buffer (depth d): an epoch is left out exactly when at least d + 1 epochs later than it, and
kept, arrived before it (d + 1 later epochs cannot all be held, so one of them was released before it came);
the kept epochs come out in time order; a repeated time keeps its first epoch (the repeat counted late when
the epoch it repeats was released long before, else repeated).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chronofuse.io.arrival import REORDER_EPOCHS, ArrivalOrder, sorted_on_arrival
from chronofuse.io.inspect import read_bytes
from chronofuse.io.sources_decode import StreamDecoder
from chronofuse.record import EpochRecord

from _recordings import _clock, ubx_recording  # noqa: E402


def _oracle(times: list[int], depth: int) -> tuple[list[int], int]:
    kept: list[int] = []
    late = 0
    for k, t in enumerate(times):
        if t in times[:k]:
            continue
        if sum(1 for u in kept if u > t) >= depth + 1:
            late += 1
            continue
        kept.append(t)
    return sorted(kept), late


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(0, 40), max_size=40), st.integers(0, 4), st.integers(1, 7))
def test_the_buffer_keeps_and_drops_what_its_definition_says_in_any_chunks(times, depth, chunk):
    expected, late = _oracle(times, depth)
    whole = ArrivalOrder(depth)
    got = whole.push(times, times) + whole.flush()
    assert got == expected
    distinct = len(set(times)) == len(times)  # a repeat of an epoch released long ago counts as late or repeated
    assert whole.n_late == late or not distinct
    assert whole.n_late + whole.n_repeated == len(times) - len(expected)
    parts = ArrivalOrder(depth)
    split = []
    for i in range(0, len(times), chunk):
        split += parts.push(times[i:i + chunk], times[i:i + chunk])
    assert split + parts.flush() == expected
    rows, order = sorted_on_arrival({"gps_ns": np.array(times, dtype=np.int64)}, depth)
    assert rows["gps_ns"].tolist() == expected and order.n_late == whole.n_late


def test_an_epoch_in_order_is_held_no_longer_than_the_buffer():
    order = ArrivalOrder()
    released = [order.push([t], [t]) for t in range(10)]
    assert released[:REORDER_EPOCHS] == [[]] * REORDER_EPOCHS
    assert all(r == [k] for k, r in enumerate(released[REORDER_EPOCHS:]))
    assert (order.n_reordered, order.n_late, order.n_repeated) == (0, 0, 0)


def _shuffled_recording() -> tuple[bytes, np.ndarray]:
    x = _clock(21)[:60]
    epochs = [ubx_recording(x[k:k + 1], start_tow_ms=100_000_000 + k * 1000) for k in range(x.size)]
    epochs[10], epochs[11] = epochs[11], epochs[10]  # one swap: put back
    epochs[30:33] = [epochs[31], epochs[32], epochs[30]]  # two late: put back
    late = epochs.pop(45)
    epochs.insert(49, late)  # four late: beyond the buffer, left out
    return b"".join(epochs), x


def _streamed(data: bytes, size: int) -> EpochRecord:
    decoder = StreamDecoder(source="<test>")
    parts = [decoder.feed_record(data[i:i + size]) for i in range(0, len(data), size)] + [decoder.close_record()]
    return EpochRecord.concat([p for p in parts if p is not None]), decoder


@pytest.mark.parametrize("size", [7, 100, 250, 1 << 20])
def test_the_batch_reader_and_the_live_decoder_give_the_same_epochs_in_any_split(size):
    data, x = _shuffled_recording()
    batch = read_bytes([data], "<test>")
    record, decoder = _streamed(data, size)
    want = [k for k in range(60) if k != 45]
    assert np.array_equal(record.t_ns, batch.rows["gps_ns"])
    assert np.array_equal((batch.rows["gps_ns"] - batch.rows["gps_ns"][0]) // 1_000_000_000, want)
    assert np.array_equal(record.column("clock_bias_s"), batch.rows["clock_bias_s"])
    assert np.allclose(batch.rows["clock_bias_s"], np.round(x[want] * 1e9) * 1e-9, rtol=0, atol=1e-15)
    assert (batch.reordered_epochs, batch.late_epochs) == (decoder.n_reordered, decoder.n_late) == (2, 1)
