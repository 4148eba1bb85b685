"""Epochs put in time order as they arrive: one bounded reorder buffer for the batch reader and the live one.

A receiver (or a logger splicing its output) can send an epoch after a later one. The batch reader used to
sort the whole file while the live decoder dropped any epoch that came behind the one it had released, so
``detect FILE`` and ``monitor --replay`` of the same bytes disagreed, and ``detect -`` depended on how the
pipe happened to split the bytes. Both now take each protocol's epochs, in the order the stream carries
them, through :class:`ArrivalOrder`: up to :data:`REORDER_EPOCHS` epochs are held, the earliest is released
when one more arrives, so an epoch that comes at most that many epochs late is put back in its place
(counted in ``n_reordered``); one later than that, behind an epoch already released, is dropped (``n_late``),
and one whose time repeats an epoch held or just released is dropped too (``n_repeated``, the first kept).

Every decision depends on the epochs before it in stream order only, so a stream pushed whole or in any
chunks gives the same epochs. Live (the monitor, and ``detect -``), an epoch is also released once it has been held
:data:`REORDER_HOLD_S` of wall time, so the output is not two epochs behind a slow receiver; the same bytes
arriving at the same times give the same epochs on every run, and a replay or a file, which arrives faster
than that, gives the batch reader's.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable

import numpy as np

__all__ = ["REORDER_EPOCHS", "REORDER_HOLD_S", "ArrivalOrder", "arrival_warnings", "in_arrival_order", "sorted_on_arrival"]

#: How many epochs the buffer holds: an epoch up to this many epochs late is put back in order.
REORDER_EPOCHS = 2

#: Live, the longest an epoch is held (wall time since it closed, s) before it is released without waiting
#: for more epochs: a monitor's output (its page, its time-server feed) is at most this much later than the
#: receiver, and an epoch that arrives behind one released sooner is late (left out and counted). A file or
#: a replay arrives faster than this, so the epoch count alone decides, as the batch reader does.
REORDER_HOLD_S = 0.5


class ArrivalOrder:
    """The bounded reorder buffer of the module docstring. :meth:`push` takes epochs in stream order (their
    ``gps_ns`` and any item standing for each) and returns the items released, in time order; :meth:`flush`
    (the end of the stream) the items still held."""

    def __init__(self, depth: int = REORDER_EPOCHS):
        if int(depth) < 0:
            raise ValueError(f"depth == {depth}, must be >= 0")
        self.depth = int(depth)
        self._heap: list = []
        self._held: set[int] = set()
        self._last: int | None = None  # the last epoch released
        self._max: int | None = None  # the latest epoch taken
        self.n_reordered = 0
        self.n_late = 0
        self.n_repeated = 0

    def push(self, gps_ns: Iterable[int], items: Iterable) -> list:
        out = []
        for g, item in zip(gps_ns, items):
            g = int(g)
            if g in self._held or g == self._last:
                self.n_repeated += 1
                continue
            if self._last is not None and g < self._last:
                self.n_late += 1
                continue
            if self._max is not None and g < self._max:
                self.n_reordered += 1
            else:
                self._max = g
            heapq.heappush(self._heap, (g, item))  # times are unique in the heap: items never compared
            self._held.add(g)
            if len(self._heap) > self.depth:
                out.append(self._pop())
        return out

    def flush(self) -> list:
        out = []
        while self._heap:
            out.append(self._pop())
        return out

    def _pop(self):
        g, item = heapq.heappop(self._heap)
        self._held.discard(g)
        self._last = g
        return item

    @property
    def n_held(self) -> int:
        return len(self._heap)

    @property
    def held(self) -> frozenset[int]:
        """The times of the epochs held."""
        return frozenset(self._held)


def in_arrival_order(rows: dict, order: ArrivalOrder, *, final: bool) -> dict:
    """Epoch rows (column arrays with ``gps_ns``, in stream order) through ``order``: the rows it releases, in
    time order (with ``final`` the ones it still holds too). Rows held back stay in ``order``."""
    n = rows["gps_ns"].size
    items = [{k: v[i] for k, v in rows.items()} for i in range(n)] if n else []
    released = order.push(rows["gps_ns"].tolist(), items)
    if final:
        released += order.flush()
    return {k: np.array([r[k] for r in released], dtype=v.dtype).reshape(len(released), *v.shape[1:])
            for k, v in rows.items()}


def sorted_on_arrival(rows: dict, depth: int = REORDER_EPOCHS) -> tuple[dict, ArrivalOrder]:
    """A whole recording's rows (in file order) as the buffer releases them: the batch reader's
    :func:`in_arrival_order`, by index (no per-epoch dicts)."""
    order = ArrivalOrder(depth)
    idx = order.push(rows["gps_ns"].tolist(), range(rows["gps_ns"].size)) + order.flush()
    index = np.asarray(idx, dtype=np.int64)
    return {k: v[index] for k, v in rows.items()}, order


def arrival_warnings(n_reordered: int, n_late: int) -> list[str]:
    """What a document says about epochs that came out of time order (none when every epoch came in order)."""
    out = []
    if n_reordered:
        out.append(f"out of order: {n_reordered} epoch(s) arrived after a later one (at most {REORDER_EPOCHS} "
                   "epochs late) and were put back in time order")
    if n_late:
        out.append(f"out of order: {n_late} epoch(s) arrived more than {REORDER_EPOCHS} epochs late and were "
                   "left out")
    return out
