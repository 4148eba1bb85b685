"""Placing time-tagged samples on a regular grid of sample slots; a missing slot becomes a gap (NaN)."""

from __future__ import annotations

import numpy as np

from chronofuse.validation import InputDataError, InputError


def grid_slots(offsets: np.ndarray, interval: float, tolerance: float) -> tuple[np.ndarray, int]:
    """Slot index of each sample: ``round(offsets / interval)``, shape (N,).

    ``offsets`` (N,) are times since the first sample (any unit, the same as ``interval``). Returns
    ``(slots, bad)`` where ``bad`` is the position of the first sample that is more than
    ``tolerance * interval`` off its slot or does not advance to a later slot than the one before
    (``-1`` when every sample is good). Slot numbers are measured from the first sample, so timing
    jitter does not accumulate over a long record.
    """
    offsets = np.asarray(offsets, dtype=np.float64)
    slots = np.rint(offsets / interval).astype(np.int64)
    off = np.abs(offsets - slots * interval) > tolerance * interval
    stuck = np.r_[False, np.diff(slots) <= 0]
    bad = np.flatnonzero(off | stuck)
    return slots, int(bad[0]) if bad.size else -1


def place_on_grid(slots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Values at their slots, NaN in the empty ones: shape ``(slots[-1] + 1, *values.shape[1:])``."""
    out = np.full((int(slots[-1]) + 1, *np.shape(values)[1:]), np.nan)
    out[slots] = values
    return out


def regular_grid(t_s: np.ndarray, values: np.ndarray, interval_s: float, source: str,
                 tolerance: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Place ``values`` (N,) at times ``t_s`` (N,) on the grid ``t_s[0] + k interval_s``; empty slots are NaN.

    A step may differ from a whole number of intervals by ``tolerance`` (a fraction of the interval).
    Returns ``(grid times (M,), grid values (M,))``.

    Raises :class:`~chronofuse.validation.InputDataError` naming ``source`` and the epoch when time does not
    increase or a step is not a whole number of intervals (a changed sampling interval).
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    steps = np.diff(t_s)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(f"epoch {k + 1}: time is not increasing ({t_s[k - 1]:g} s then {t_s[k]:g} s)", source)
    slots, bad = grid_slots(t_s - t_s[0], interval_s, tolerance)
    if bad >= 0:
        raise InputDataError(
            f"epoch {bad + 1}: time step {steps[bad - 1]:g} s is not a whole number of {interval_s:g} s intervals "
            "(the sampling interval changed: a new interval needs a new detector, check {rate_hz})",
            source, fields=("rate_hz",))
    grid = place_on_grid(slots, values)
    return t_s[0] + np.arange(grid.size) * interval_s, grid


def snap_interval_ns(step_ns: int, resolution_ns: int | None) -> int:
    """A measured step (ns) as a grid interval: a whole number of ``resolution_ns`` (u-blox ``iTOW`` is in ms),
    or, without a resolution, rounded to 6 significant digits (a text file's time column written as
    0.1 s or 300 s; the rule the record reader snaps its least-squares interval with)."""
    if resolution_ns is None:
        quantum = 10 ** max(int(np.floor(np.log10(step_ns))) - 5, 0)
    else:
        quantum = int(resolution_ns)
    return max(int(round(step_ns / quantum)) * quantum, quantum)


#: Integer columns whose value holds through a gap (a leap count does not vanish); others are 0 there.
_CARRIED = ("leap_s",)


class GridPlacer:
    """Places the epochs of a record, as they arrive in chunks, on the regular grid ``t0 + k * interval``.

    ``t0`` is the first epoch's time tag; the interval is ``interval_ns`` when given, else learnt from the first
    ``learn_steps`` steps: their lower median, snapped by :func:`snap_interval_ns`. Each epoch goes to its
    nearest slot and must sit within ``tolerance`` of an interval of it (a receiver tags its solutions on its
    own clock: u-blox ``iTOW`` steps by 999 or 1001 ms now and then) and in a later slot than the epoch
    before; an empty slot becomes a gap epoch (float columns NaN, ``valid`` True: a gap says nothing bad,
    ``n_sats`` -1, ``leap_s`` carried from the epoch before, other integers and flags 0, provenance -1). The gridded
    epochs carry the grid's times (``t_ns`` exact integers) and ``interval_ns``, and the column ``tag_offset_s``
    (each epoch's own time tag less its slot's time, s; NaN in a gap); ``info`` holds ``n_gaps``,
    ``jitter_rms_s`` and ``jitter_max_s`` (the tags' distance from their slots) so far.

    Every decision depends only on the epochs before it (the interval on the first ``learn_steps + 1``), so
    pushing a record whole or in any chunks gives the same epochs: the batch reader and a live stream
    share the grid. Until the interval is known, epochs wait (``push`` returns None); :meth:`close` places
    what waits (the interval from the steps there are; one epoch alone needs ``interval_ns``).

    Errors (:class:`~chronofuse.validation.InputDataError`) name the source and the epoch's line or offset.
    """

    def __init__(self, interval_ns: int | None = None, *, learn_steps: int = 8, resolution_ns: int | None = None,
                 tolerance: float = 0.05):
        if interval_ns is not None and int(interval_ns) <= 0:
            raise ValueError(f"interval_ns == {interval_ns}, must be > 0")
        self.interval_ns = None if interval_ns is None else int(interval_ns)
        self.learn_steps = int(learn_steps)
        self.resolution_ns = resolution_ns
        self.tolerance = float(tolerance)
        self._waiting: list = []
        self._t0: int | None = None
        self._last_slot = -1
        self._last_t: int | None = None
        self._carry: dict = {}
        self._n_gaps = 0
        self._sum_sq = 0.0
        self._max = 0.0
        self._n_placed = 0

    def push(self, record):
        """Place ``record``'s epochs (``lead == ()``); the gridded epochs ready so far, or None."""
        if record is None or record.n_epochs == 0:
            return None
        if record.lead:
            raise ValueError(f"a grid places one stream (lead ()), not lead axes {record.lead}")
        self._check_increasing(record)
        if self.interval_ns is None:
            self._waiting.append(record)
            if sum(r.n_epochs for r in self._waiting) <= self.learn_steps:
                return None
            self._learn()
        return self._release(record)

    def close(self):
        """End of the stream: the epochs still waiting for the interval, placed (None when there are none)."""
        if self.interval_ns is None and self._waiting:
            self._learn()
            return self._release(None)
        return None

    def _check_increasing(self, record) -> None:
        t = record.t_ns
        before = self._last_t if self._last_t is not None else t[0] - 1
        steps = np.diff(np.concatenate(([before], t)))
        if (steps <= 0).any():
            k = int(np.flatnonzero(steps <= 0)[0])
            prev = before if k == 0 else int(t[k - 1])
            raise self._error(record, k, f"time is not increasing ({prev} ns then {int(t[k])} ns)")
        self._last_t = int(t[-1])

    def _learn(self) -> None:
        from chronofuse.record import EpochRecord

        waiting = EpochRecord.concat(self._waiting)
        steps = np.diff(waiting.t_ns)[: self.learn_steps]
        if steps.size == 0:
            raise InputError("one epoch and no sampling rate ({rate_hz}): the interval is unknown", waiting.source,
                             fields=("rate_hz",))
        lower_median = int(np.partition(steps, (steps.size - 1) // 2)[(steps.size - 1) // 2])
        self.interval_ns = snap_interval_ns(lower_median, self.resolution_ns)

    def _release(self, record):
        from chronofuse.record import EpochRecord

        if self._waiting:
            record = EpochRecord.concat(self._waiting)
            self._waiting = []
        if record is None:
            return None
        interval = self.interval_ns
        t = record.t_ns
        if self._t0 is None:
            self._t0 = int(t[0])
        offset = t - self._t0
        slots = (offset + interval // 2) // interval
        resid = offset - slots * interval
        bad_off = np.abs(resid) > self.tolerance * interval
        prev = np.concatenate(([self._last_slot], slots[:-1]))
        bad = np.flatnonzero(bad_off | (slots <= prev))
        if bad.size:
            k = int(bad[0])
            step_ns = int(t[k]) - (int(t[k - 1]) if k else self._t0 + self._last_slot * interval)
            raise self._error(record, k, f"time step {step_ns / 1e9:g} s is not a whole number of {interval / 1e9:g} s "
                                         "intervals (the sampling interval changed; check {rate_hz})",
                              fields=("rate_hz",))
        r = resid / 1e9
        self._sum_sq += float(np.sum(r * r))
        self._max = max(self._max, float(np.abs(r).max()))
        self._n_placed += t.size
        first = self._last_slot + 1
        n = int(slots[-1]) - first + 1
        at = slots - first
        self._n_gaps += n - t.size
        self._last_slot = int(slots[-1])
        columns = {}
        for name, values in record.columns.items():
            out = np.empty(n, dtype=values.dtype)
            out[:] = self._gap_value(name, values)
            out[at] = values
            if name in _CARRIED:
                filled = np.maximum.accumulate(np.where(np.isin(np.arange(n), at), np.arange(n), -1))
                have = filled >= 0
                out[have] = out[filled[have]]
            columns[name] = out
            if values.size:
                self._carry[name] = values[-1]
        offset_s = np.full(n, np.nan)
        offset_s[at] = r  # each epoch's time tag less its slot's time: where the source put it
        columns["tag_offset_s"] = offset_s
        valid = np.ones(n, dtype=bool)
        valid[at] = record.valid
        position = np.full(n, -1, dtype=np.int64)
        position[at] = record.provenance.position
        info = {**record.info, "n_gaps": self._n_gaps, "jitter_rms_s": float(np.sqrt(self._sum_sq / self._n_placed)),
                "jitter_max_s": self._max}
        return EpochRecord.from_arrays(self._t0 + (first + np.arange(n, dtype=np.int64)) * interval, columns,
                                       {**record.units, "tag_offset_s": "s"}, source=record.source, valid=valid, interval_ns=interval,
                                       time_scale=record.time_scale, position=position,
                                       position_unit=record.provenance.unit, info=info)

    def _gap_value(self, name: str, values: np.ndarray):
        if values.dtype.kind == "f":
            return np.nan
        if name == "n_sats":
            return -1
        if name in _CARRIED:
            return self._carry.get(name, values[0] if values.size else 0)
        return 0

    @staticmethod
    def _error(record, k: int, message: str, fields: tuple[str, ...] = ()) -> InputDataError:
        prov = record.provenance
        p = int(prov.position[k])
        if prov.unit == "line" and p >= 0:
            return InputDataError(message, prov.source, p, fields=fields)
        where = {"byte": f"byte {p}", "index": f"epoch {p + 1}"}.get(prov.unit, "")
        return InputDataError(f"{where}: {message}" if p >= 0 else message, prov.source, fields=fields)


__all__ = ["GridPlacer", "grid_slots", "place_on_grid", "regular_grid", "snap_interval_ns"]
