"""The one epoch record: what every reader and every simulator yields, and what every pipeline consumes.

An :class:`EpochRecord` is a table of epochs:

* ``t_ns`` (epochs,) int64, strictly increasing: each epoch's time tag in integer nanoseconds, never one
  float64 (at today's GPS seconds a float64 steps by ~0.2 us). ``time_scale`` says on which axis:
  ``"gps"`` (GPS ns since 1980-01-06, :mod:`chronofuse.timescale`) or ``"file"`` (the source's own axis,
  e.g. a CSV time column of UNIX seconds or MJD, converted exactly to ns; or the sample number times the
  interval when the source has no time column).
* ``interval_ns``: the regular grid the epochs sit on (``t_ns[0] + k * interval_ns``, a missing slot holding
  NaN values), or None for epochs as a source reported them (not placed on a grid yet:
  :class:`chronofuse.io.grid.GridPlacer` places them).
* ``columns``: named arrays of shape ``lead + (epochs,)``; ``lead`` is ``()`` for one stream and
  ``(trials, receivers)`` for a simulation or several receivers logged together (the layout of
  :class:`chronofuse.epochs.ReceiverEpochs`). ``units`` gives each column's unit (:data:`UNITS`).
* ``valid`` (``lead + (epochs,)``, bool): the source vouches for the epoch's measurements (a receiver that
  reported "no fix" does not; an epoch it did not report at all says nothing bad). A missing value is NaN
  in its float column; ``valid`` is what the source *says* about the epoch.
* ``provenance``: where each epoch came from (:class:`Provenance`: the source, and per epoch a 1-based
  line, a byte offset in the stream, or an index).
* ``info``: counts the reader kept (damaged frames, jitter of the time tags against the grid, ...).

Records are frozen and their arrays read-only. A stream is a sequence of records (chunks) over
consecutive epochs; :meth:`EpochRecord.concat` joins chunks and ``record[a:b]`` cuts one, so a batch
path and a streaming path see the same epochs.

This module sits at the top of the package (beside :mod:`chronofuse.timescale` and
:mod:`chronofuse.epochs`) because the simulators in :mod:`chronofuse.models` produce records too and
models may not import :mod:`chronofuse.io`; :mod:`chronofuse.io` re-exports it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

__all__ = ["EpochRecord", "Provenance", "UNITS", "RECEIVER_UNITS", "TIME_SCALES", "POSITION_UNITS"]

#: Units a column may carry: seconds, s/s (a fractional frequency or a clock drift), dimensionless,
#: metres, a gpsd fix mode (0 unknown, 1 none, 2 2-D, 3 3-D), a count, a flag.
UNITS = ("s", "s/s", "1", "m", "mode", "count", "flag")

#: The receiver columns (the fields of :class:`chronofuse.epochs.ReceiverEpochs`) and their units.
RECEIVER_UNITS = MappingProxyType({
    "fix_mode": "mode", "time_valid": "flag", "n_sats": "count", "gdop": "1", "pdop": "1", "hdop": "1",
    "vdop": "1", "tdop": "1", "leap_s": "s", "leap_pending": "count", "qerr_s": "s", "clock_bias_s": "s",
    "clock_drift_s_per_s": "s/s", "time_acc_s": "s",
})

#: Axes ``t_ns`` may be on (module docstring).
TIME_SCALES = ("gps", "file")

#: What :attr:`Provenance.position` counts.
POSITION_UNITS = ("line", "byte", "index")


def _read_only(a) -> np.ndarray:
    view = np.asarray(a).view()
    view.flags.writeable = False
    return view


@dataclass(frozen=True)
class Provenance:
    """Where each epoch of a record came from.

    ``source``: the file path, ``<stdin>``, a live source spec (``serial:/dev/ttyUSB0@9600``) or the
    simulator's name and seed. ``unit``: what ``position`` counts (:data:`POSITION_UNITS`): the 1-based line
    of a text source, the byte offset of the epoch's first frame in a byte stream, or the epoch's 0-based
    index in the source. ``position`` (epochs,) int64, -1 where unknown (an epoch the grid filled in).
    """

    source: str
    unit: str
    position: np.ndarray

    def __post_init__(self):
        if self.unit not in POSITION_UNITS:
            raise ValueError(f"unit == {self.unit!r}, must be one of {POSITION_UNITS}")
        position = np.asarray(self.position)
        if position.ndim != 1 or position.dtype.kind not in "iu":
            raise ValueError(f"position has shape {position.shape} and dtype {position.dtype}, must be (epochs,) int")
        object.__setattr__(self, "position", _read_only(position.astype(np.int64, copy=False)))

    def where(self, k: int) -> str:
        """Epoch ``k`` as ``source:line``, ``source@byte`` or ``source[index]`` (``source`` alone if unknown)."""
        p = int(self.position[k])
        if p < 0:
            return self.source
        return {"line": f"{self.source}:{p}", "byte": f"{self.source}@{p}", "index": f"{self.source}[{p}]"}[self.unit]


@dataclass(frozen=True)
class EpochRecord:
    """Epochs with named columns, a validity mask and provenance (module docstring)."""

    t_ns: np.ndarray
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    valid: np.ndarray
    provenance: Provenance
    interval_ns: int | None = None
    time_scale: str = "gps"
    info: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t_ns)
        if t.ndim != 1 or t.dtype != np.int64:
            raise ValueError(f"t_ns has shape {t.shape} and dtype {t.dtype}, must be (epochs,) int64")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
            raise ValueError(f"t_ns must be strictly increasing ({int(t[k - 1])} then {int(t[k])} at epoch {k})")
        object.__setattr__(self, "t_ns", _read_only(t))
        if self.time_scale not in TIME_SCALES:
            raise ValueError(f"time_scale == {self.time_scale!r}, must be one of {TIME_SCALES}")
        if self.interval_ns is not None:
            if int(self.interval_ns) <= 0:
                raise ValueError(f"interval_ns == {self.interval_ns}, must be > 0 (or None: not on a grid)")
            object.__setattr__(self, "interval_ns", int(self.interval_ns))
        valid = np.asarray(self.valid)
        if valid.dtype != np.bool_ or valid.shape[-1:] != (t.size,):
            raise ValueError(f"valid has shape {valid.shape} and dtype {valid.dtype}, must be bool (..., {t.size})")
        object.__setattr__(self, "valid", _read_only(valid))
        columns = {}
        for name, values in self.columns.items():
            a = np.asarray(values)
            if a.shape != valid.shape:
                raise ValueError(f"column {name} has shape {a.shape}, must be {valid.shape} like valid")
            if name not in self.units:
                raise ValueError(f"column {name} has no unit (units must name every column)")
            columns[name] = _read_only(a)
        for name, unit in self.units.items():
            if unit not in UNITS:
                raise ValueError(f"unit of {name} == {unit!r}, must be one of {UNITS}")
        object.__setattr__(self, "columns", MappingProxyType(columns))
        object.__setattr__(self, "units", MappingProxyType({n: self.units[n] for n in columns}))
        if self.provenance.position.shape != (t.size,):
            raise ValueError(f"provenance has {self.provenance.position.size} positions for {t.size} epochs")
        object.__setattr__(self, "info", MappingProxyType(dict(self.info)))

    # -- shape ------------------------------------------------------------------------------------------

    @property
    def n_epochs(self) -> int:
        return int(self.t_ns.size)

    @property
    def lead(self) -> tuple[int, ...]:
        """The axes before the epoch axis: ``()`` for one stream, ``(trials, receivers)`` for a simulation."""
        return self.valid.shape[:-1]

    @property
    def source(self) -> str:
        return self.provenance.source

    @property
    def interval_s(self) -> float:
        """The grid interval in seconds (a duration, float), NaN when the record is not on a grid."""
        return float("nan") if self.interval_ns is None else self.interval_ns / 1e9

    def __getitem__(self, epochs: slice) -> EpochRecord:
        """The epochs ``epochs`` (a slice of the epoch axis), every column cut alike."""
        if not isinstance(epochs, slice):
            raise TypeError(f"a record is cut with a slice of epochs, not {type(epochs).__name__}")
        prov = dataclasses.replace(self.provenance, position=self.provenance.position[epochs])
        return dataclasses.replace(self, t_ns=self.t_ns[epochs], valid=self.valid[..., epochs],
                                   columns={n: v[..., epochs] for n, v in self.columns.items()}, provenance=prov)

    def take(self, mask) -> EpochRecord:
        """The epochs where ``mask`` (epochs,) is True (off any grid: ``interval_ns`` becomes None)."""
        mask = np.asarray(mask, dtype=bool)
        prov = dataclasses.replace(self.provenance, position=self.provenance.position[mask])
        return dataclasses.replace(self, t_ns=self.t_ns[mask], valid=self.valid[..., mask], interval_ns=None,
                                   columns={n: v[..., mask] for n, v in self.columns.items()}, provenance=prov)

    def select(self, *index: int) -> EpochRecord:
        """One element of the lead axes (e.g. ``select(trial, receiver)``): a record with ``lead == ()``."""
        if len(index) != len(self.lead):
            raise ValueError(f"select takes {len(self.lead)} indices (lead axes {self.lead}), got {len(index)}")
        return dataclasses.replace(self, valid=self.valid[index], columns={n: v[index] for n, v in self.columns.items()})

    def chunks(self, size: int) -> Iterable[EpochRecord]:
        """Consecutive records of ``size`` epochs (the last shorter): a stream of this record."""
        if size < 1:
            raise ValueError(f"size == {size}, must be >= 1")
        for a in range(0, self.n_epochs, size):
            yield self[a : a + size]

    # -- columns ----------------------------------------------------------------------------------------

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def column(self, name: str, default=None) -> np.ndarray:
        """Column ``name``; ``default`` (broadcast to the record's shape) when the record lacks it, or a
        ``KeyError`` naming the columns it has when no default is given."""
        if name in self.columns:
            return self.columns[name]
        if default is None:
            raise KeyError(f"the record from {self.source} has no column {name!r} (it has {sorted(self.columns)})")
        return np.broadcast_to(np.asarray(default), self.valid.shape)

    def with_columns(self, units: Mapping[str, str] | None = None, **columns) -> EpochRecord:
        """A copy with ``columns`` added or replaced (``units`` for new ones)."""
        return dataclasses.replace(self, columns={**self.columns, **columns}, units={**self.units, **(units or {})})

    def frame(self) -> dict[str, np.ndarray]:
        """The columns with ``t_ns`` and ``valid``: what a pipeline's ``run`` takes."""
        t = np.broadcast_to(self.t_ns, self.valid.shape)
        return {"t_ns": t, "valid": self.valid, **self.columns}

    # -- joining --------------------------------------------------------------------------------------

    @classmethod
    def concat(cls, records: Iterable[EpochRecord]) -> EpochRecord:
        """Consecutive chunks of one stream as one record (same columns, units, source and grid)."""
        parts = [r for r in records if r is not None and r.n_epochs]
        if not parts:
            raise ValueError("no epochs to join")
        first = parts[0]
        if len(parts) == 1:
            return first
        for r in parts[1:]:
            if set(r.columns) != set(first.columns) or r.lead != first.lead or r.time_scale != first.time_scale:
                raise ValueError("chunks differ in columns, lead axes or time scale")
        info = dict(first.info)
        for r in parts[1:]:
            info.update(r.info)
        prov = Provenance(first.provenance.source, first.provenance.unit,
                          np.concatenate([r.provenance.position for r in parts]))
        grids = {r.interval_ns for r in parts}
        return cls(t_ns=np.concatenate([r.t_ns for r in parts]),
                   columns={n: np.concatenate([r.columns[n] for r in parts], axis=-1) for n in first.columns},
                   units=dict(first.units), valid=np.concatenate([r.valid for r in parts], axis=-1), provenance=prov,
                   interval_ns=grids.pop() if len(grids) == 1 else None, time_scale=first.time_scale, info=info)

    @classmethod
    def from_arrays(cls, t_ns, columns: Mapping[str, np.ndarray], units: Mapping[str, str], *, source: str,
                    valid=None, interval_ns: int | None = None, time_scale: str = "gps", position=None,
                    position_unit: str = "index", info: Mapping | None = None) -> EpochRecord:
        """A record from arrays: ``valid`` all True and positions ``0 .. epochs - 1`` unless given; ``t_ns`` must be
        integers (a float time tag is refused, never rounded)."""
        t = np.asarray(t_ns)
        if t.dtype.kind not in "iu":
            raise ValueError(f"t_ns has dtype {t.dtype}, must be integer nanoseconds (int64)")
        t = t.astype(np.int64, copy=False)
        shape = np.shape(next(iter(columns.values()))) if columns else t.shape
        valid = np.ones(shape, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
        position = np.arange(t.size, dtype=np.int64) if position is None else position
        return cls(t_ns=t, columns=dict(columns), units=dict(units), valid=valid,
                   provenance=Provenance(source, position_unit, position), interval_ns=interval_ns,
                   time_scale=time_scale, info=dict(info or {}))
