"""What a GNSS timing receiver reports every epoch: :class:`ReceiverEpochs`, shared by every layer.

The simulated receiver (:func:`chronofuse.models.receiver.simulate_receivers`) produces it, the NMEA/UBX
readers produce it from real logs, and the disciplined oscillator and the monitor consume it. It holds
only what a receiver *says* (its navigation solution and its time messages); what is true (the 1PPS edge
error, a spoofer's drag-off) stays in the simulator's ``ReceiverTruth``.

Layout (one, explicit, never reshaped)
--------------------------------------
``gps_ns`` has shape ``(epochs,)``: the epoch grid, int64 GPS nanoseconds since 1980-01-06T00:00:00
(:mod:`chronofuse.timescale`), the GPS time at which each solution and its 1PPS edge are valid. Every
other field has shape ``(trials, receivers, epochs)``: Monte Carlo trial, receiver, epoch. A real log is
one trial of one receiver, ``(1, 1, epochs)``; receivers logged together share the grid (an epoch a
receiver did not report has ``fix_mode == 0`` and NaN measurements). Fields may be read-only broadcast
views (a leap-second count common to all receivers costs one row).

Fields and their "absent" value (what a receiver that does not report the field gives)
--------------------------------------------------------------------------------------
- ``fix_mode`` (int8): gpsd's TPV ``mode``: 0 unknown (no report), 1 no fix, 2 2-D fix, 3 3-D or
  time-only fix.
- ``time_valid`` (bool): the receiver vouches for its time (u-blox NAV-PVT ``validTime``; NMEA RMC
  status ``A``).
- ``n_sats`` (int16): satellites used in the solution; -1 absent.
- ``gdop``, ``pdop``, ``hdop``, ``vdop``, ``tdop`` (float64): dilutions of precision; NaN absent.
- ``leap_s`` (int16): GPS - UTC as the receiver announces it, s (18 since 2017-01-01).
- ``leap_pending`` (int8): announced leap second at the end of the current UTC day: +1 insert, -1
  delete, 0 none.
- ``qerr_s`` (float64): u-blox UBX-TIM-TP ``qErr`` of the coming 1PPS edge, s, with u-blox's sign
  (*adding* it to a counter's reading of the edge removes the quantization sawtooth); NaN absent.
- ``clock_bias_s`` (float64): receiver clock bias against GNSS time (UBX-NAV-CLOCK ``clkB``), s; NaN absent.
- ``clock_drift_s_per_s`` (float64): its rate (``clkD``), s/s; NaN absent.

UTC: the receiver's UTC label of an epoch is ``gps_ns - leap_s * NS_PER_S`` (:meth:`ReceiverEpochs.utc_ns`),
the POSIX-style count that :func:`chronofuse.timescale.gps_ns_to_utc` also uses (an inserted leap second
repeats the label of the following midnight). It follows the receiver's ``leap_s``, not the leap-second
table, so a receiver with a wrong or future leap count shows it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd

from chronofuse.record import RECEIVER_UNITS, EpochRecord
from chronofuse.timescale import NS_PER_S, gps_ns_to_datetime64
from chronofuse.validation import check_scalar

__all__ = ["ReceiverEpochs", "FIX_MODES", "EXPORT_COLUMNS", "FIELDS"]

#: gpsd TPV ``mode`` values: 0 unknown, 1 no fix, 2 2-D, 3 3-D (or time-only).
FIX_MODES = (0, 1, 2, 3)

#: Columns of :meth:`ReceiverEpochs.to_frame`, in order.
EXPORT_COLUMNS = ("time_utc", "mode", "n_sats", "gdop", "pdop", "hdop", "vdop", "tdop", "leap_s",
                  "clock_bias_s", "clock_drift", "qerr_s")

# Per-receiver fields: (name, dtype kind the input must have, stored dtype).
_INT, _FLOAT, _BOOL = "iu", "f", "b"
_FIELDS = (
    ("fix_mode", _INT, np.int8),
    ("time_valid", _BOOL, np.bool_),
    ("n_sats", _INT, np.int16),
    ("gdop", _FLOAT, np.float64),
    ("pdop", _FLOAT, np.float64),
    ("hdop", _FLOAT, np.float64),
    ("vdop", _FLOAT, np.float64),
    ("tdop", _FLOAT, np.float64),
    ("leap_s", _INT, np.int16),
    ("leap_pending", _INT, np.int8),
    ("qerr_s", _FLOAT, np.float64),
    ("clock_bias_s", _FLOAT, np.float64),
    ("clock_drift_s_per_s", _FLOAT, np.float64),
)
_ABSENT_FLOAT = tuple(name for name, kind, _ in _FIELDS if kind == _FLOAT)
#: The per-receiver fields, in order (the receiver columns of :class:`chronofuse.record.EpochRecord`).
FIELDS = tuple(name for name, _, _ in _FIELDS)


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


@dataclass(frozen=True)
class ReceiverEpochs:
    """Per-epoch reports of ``receivers`` receivers over ``trials`` trials (see the module docstring).

    Construct it with every field (use :meth:`absent` for fields a source does not report). The
    constructor checks each field's shape and dtype kind, casts to the stored dtype (values must fit:
    ``n_sats`` in [-1, 32767], ``fix_mode`` in :data:`FIX_MODES`, ``leap_pending`` in {-1, 0, 1}),
    and holds read-only arrays. ``gps_ns`` must be strictly increasing.
    """

    gps_ns: np.ndarray
    fix_mode: np.ndarray
    time_valid: np.ndarray
    n_sats: np.ndarray
    gdop: np.ndarray
    pdop: np.ndarray
    hdop: np.ndarray
    vdop: np.ndarray
    tdop: np.ndarray
    leap_s: np.ndarray
    leap_pending: np.ndarray
    qerr_s: np.ndarray
    clock_bias_s: np.ndarray
    clock_drift_s_per_s: np.ndarray

    def __post_init__(self):
        gps_ns = np.asarray(self.gps_ns)
        if gps_ns.ndim != 1 or gps_ns.size == 0 or gps_ns.dtype != np.int64:
            raise ValueError(f"gps_ns has shape {gps_ns.shape} and dtype {gps_ns.dtype}, must be (epochs,) int64 "
                             "with epochs >= 1")
        if np.any(np.diff(gps_ns) <= 0):
            raise ValueError("gps_ns must be strictly increasing")
        object.__setattr__(self, "gps_ns", _read_only(gps_ns))
        cube = None
        for name, kind, dtype in _FIELDS:
            value = np.asarray(getattr(self, name))
            if cube is None:
                cube = value.shape
                if len(cube) != 3 or cube[2] != gps_ns.size:
                    raise ValueError(f"{name} has shape {cube}, must be (trials, receivers, {gps_ns.size})")
            if value.shape != cube:
                raise ValueError(f"{name} has shape {value.shape}, must be {cube}")
            if value.dtype.kind not in kind:
                raise ValueError(f"{name} has dtype {value.dtype}, must be of kind {kind!r}")
            stored = value if value.dtype == dtype else self._cast(name, value, dtype)
            object.__setattr__(self, name, _read_only(stored))
        self._check_values()

    @staticmethod
    def _cast(name: str, value: np.ndarray, dtype) -> np.ndarray:
        if np.dtype(dtype).kind == "i":
            info = np.iinfo(dtype)
            if value.size and (value.min() < info.min or value.max() > info.max):
                raise ValueError(f"{name} spans {value.min()}..{value.max()}, must fit {np.dtype(dtype).name}")
        return value.astype(dtype)

    def _check_values(self) -> None:
        if not np.isin(self.fix_mode, FIX_MODES).all():
            raise ValueError(f"fix_mode holds {np.setdiff1d(self.fix_mode, FIX_MODES)}, must be in {FIX_MODES}")
        if not np.isin(self.leap_pending, (-1, 0, 1)).all():
            raise ValueError(f"leap_pending holds {np.setdiff1d(self.leap_pending, (-1, 0, 1))}, must be -1, 0 or 1")
        if self.n_sats.size and self.n_sats.min() < -1:
            raise ValueError(f"n_sats has {self.n_sats.min()}, must be >= 0 (or -1 absent)")

    @classmethod
    def absent(cls, gps_ns: np.ndarray, trials: int, receivers: int, *, leap_s) -> dict[str, np.ndarray]:
        """Keyword arguments for a source that reports nothing: fix mode 0, no valid time, ``n_sats``
        -1, NaN measurements, no pending leap, ``leap_s`` (scalar or broadcastable to the cube).

        Override the fields the source does report: ``ReceiverEpochs(**{**ReceiverEpochs.absent(...), ...})``.
        Arrays are read-only broadcast views (no memory per epoch).
        """
        check_scalar(trials, "trials", min_val=1, integer=True)
        check_scalar(receivers, "receivers", min_val=1, integer=True)
        gps_ns = np.asarray(gps_ns, dtype=np.int64)
        cube = (int(trials), int(receivers), gps_ns.size)

        def full(value, dtype):
            return np.broadcast_to(np.asarray(value, dtype=dtype), cube)

        fields = {"gps_ns": gps_ns, "fix_mode": full(0, np.int8), "time_valid": full(False, np.bool_),
                  "n_sats": full(-1, np.int16), "leap_s": full(leap_s, np.int16), "leap_pending": full(0, np.int8)}
        fields.update({name: full(np.nan, np.float64) for name in _ABSENT_FLOAT})
        return fields

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(trials, receivers, epochs)``."""
        return self.fix_mode.shape

    @property
    def has_fix(self) -> np.ndarray:
        """``fix_mode >= 2``: a 2-D or 3-D (or time-only) fix, shape ``(trials, receivers, epochs)``."""
        return self.fix_mode >= 2

    def utc_ns(self) -> np.ndarray:
        """The receiver's UTC label of each epoch, int64 ns since the GPS epoch on the UTC scale:
        ``gps_ns - leap_s * NS_PER_S``, shape ``(trials, receivers, epochs)``."""
        return self.gps_ns - self.leap_s.astype(np.int64) * NS_PER_S

    def select(self, receiver: int, trial: int = 0) -> ReceiverEpochs:
        """One receiver of one trial, keeping the layout: shape ``(1, 1, epochs)``."""
        trials, receivers, _ = self.shape
        check_scalar(trial, "trial", min_val=0, max_val=trials - 1, integer=True)
        check_scalar(receiver, "receiver", min_val=0, max_val=receivers - 1, integer=True)
        i, j = int(trial), int(receiver)
        return dataclasses.replace(self, **{name: getattr(self, name)[i : i + 1, j : j + 1] for name, _, _ in _FIELDS})

    def to_record(self, source: str, *, time_acc_s=None, position=None, position_unit: str = "index",
                  info=None) -> EpochRecord:
        """These epochs as the one epoch record: ``t_ns`` = ``gps_ns`` (GPS scale), one column per field
        (units :data:`chronofuse.record.RECEIVER_UNITS`), lead axes ``(trials, receivers)``, ``valid`` where
        the receiver did not report "no fix" (``fix_mode != 1``: an epoch it did not report says nothing
        bad). ``time_acc_s`` (the cube's shape, s) adds the receiver's time accuracy estimate."""
        columns = {name: getattr(self, name) for name in FIELDS}
        if time_acc_s is not None:
            columns["time_acc_s"] = np.broadcast_to(np.asarray(time_acc_s, dtype=np.float64), self.shape)
        return EpochRecord.from_arrays(self.gps_ns, columns, {n: RECEIVER_UNITS[n] for n in columns}, source=source,
                                       valid=self.fix_mode != 1, position=position, position_unit=position_unit,
                                       info=info)

    @classmethod
    def from_record(cls, record: EpochRecord) -> ReceiverEpochs:
        """The receiver fields of a GPS-scale record with lead axes ``(trials, receivers)`` (or none: one
        receiver of one trial); fields the record lacks are absent (:meth:`absent`, leap count from the table)."""
        from chronofuse.timescale import gps_minus_utc_s

        if record.time_scale != "gps":
            raise ValueError(f"the record from {record.source} is on the {record.time_scale!r} time axis; receiver "
                             "epochs are on GPS time")
        lead = record.lead if record.lead else (1, 1)
        if len(lead) != 2:
            raise ValueError(f"the record's lead axes are {record.lead}, must be (trials, receivers) or none")

        def cube(a):
            return np.asarray(a).reshape(lead + (record.n_epochs,))

        leap = record.column("leap_s") if "leap_s" in record else gps_minus_utc_s(record.t_ns)
        fields = cls.absent(record.t_ns, *lead, leap_s=cube(np.broadcast_to(leap, record.valid.shape)))
        fields.update({name: cube(record.columns[name]) for name in FIELDS if name in record})
        return cls(**fields)

    def to_frame(self, receiver: int = 0, trial: int = 0) -> pd.DataFrame:
        """One receiver of one trial as a table, one row per epoch, columns :data:`EXPORT_COLUMNS`.

        ``time_utc`` is the receiver's UTC label (:meth:`utc_ns`) in ISO 8601 with milliseconds and ``Z``
        (``2025-01-01T00:00:00.000Z``), or nanoseconds when an epoch has a part of a millisecond; ``mode`` is ``fix_mode``; ``clock_drift`` is
        ``clock_drift_s_per_s``; seconds stay seconds. Absent values are NaN (``n_sats`` -1).
        """
        one = self.select(receiver, trial)
        utc_ns = one.utc_ns()[0, 0]
        unit = "ms" if np.all(utc_ns % 1_000_000 == 0) else "ns"  # sub-millisecond tags keep their digits
        columns = {
            "time_utc": np.datetime_as_string(gps_ns_to_datetime64(utc_ns), unit=unit, timezone="UTC"),
            "mode": one.fix_mode[0, 0],
            "n_sats": one.n_sats[0, 0],
            "gdop": one.gdop[0, 0],
            "pdop": one.pdop[0, 0],
            "hdop": one.hdop[0, 0],
            "vdop": one.vdop[0, 0],
            "tdop": one.tdop[0, 0],
            "leap_s": one.leap_s[0, 0],
            "clock_bias_s": one.clock_bias_s[0, 0],
            "clock_drift": one.clock_drift_s_per_s[0, 0],
            "qerr_s": one.qerr_s[0, 0],
        }
        return pd.DataFrame({name: np.array(columns[name]) for name in EXPORT_COLUMNS})
