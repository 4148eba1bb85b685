"""Time scales and epochs: integer nanoseconds, GPS/UTC/TAI, the leap-second table, GPS week and TOW.

An absolute epoch is never one float64 (at today's GPS seconds a float64 steps by ~0.2 us, at today's MJD
in seconds by ~1 us). Epochs here are ``int64`` nanoseconds since the GPS epoch (1980-01-06T00:00:00 UTC,
when GPS time equalled UTC), "GPS ns" for short; durations may be float seconds.

Scales (IS-GPS-200 20.3.3.5.2.4; IERS Bulletin C):

* TAI - GPS = 19 s exactly, for all time.
* TAI - UTC = the leap-second count, a step function of UTC (table below, from IERS Bulletin C; the last
  leap second was inserted at the end of 2016-12-31, none announced since, valid through Bulletin C 70).
* GPS - UTC = (TAI - UTC) - 19 s: 18 s since 2017-01-01.

GPS week and time of week: ``week = floor(gps_s / 604800)``, ``tow = gps_s - week * 604800``. Legacy
navigation messages carry the week modulo 1024 (rollovers on 1999-08-22 and 2019-04-07); a receiver
firmware that assumes the wrong era reports dates 1024 weeks (19.6 years) early: :func:`resolve_week`
picks the era nearest a reference epoch.
"""

from __future__ import annotations

import numpy as np

from chronofuse.validation import InputError

__all__ = [
    "NS_PER_S",
    "SECONDS_PER_DAY",
    "SECONDS_PER_WEEK",
    "NS_PER_WEEK",
    "MS_PER_WEEK",
    "WEEK_ROLLOVER",
    "GPS_EPOCH",
    "TAI_MINUS_GPS_S",
    "LEAP_SECONDS",
    "MJD_OF_GPS_EPOCH",
    "datetime64_to_gps_ns",
    "gps_ns_to_datetime64",
    "tai_minus_utc_s",
    "gps_minus_utc_s",
    "utc_to_gps_ns",
    "gps_ns_to_utc",
    "week_tow",
    "gps_ns_from_week_tow",
    "resolve_week",
    "seconds_to_ns",
]

NS_PER_S = 1_000_000_000
SECONDS_PER_DAY = 86_400
SECONDS_PER_WEEK = 7 * SECONDS_PER_DAY
NS_PER_WEEK = SECONDS_PER_WEEK * NS_PER_S
MS_PER_WEEK = SECONDS_PER_WEEK * 1000
#: Legacy GPS navigation messages carry the week number modulo 1024 (10 bits).
WEEK_ROLLOVER = 1024

#: The GPS epoch, as a UTC calendar instant (GPS time equalled UTC then).
GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")
#: Modified Julian Date of the GPS epoch.
MJD_OF_GPS_EPOCH = 44_244
#: TAI - GPS, exact (IS-GPS-200).
TAI_MINUS_GPS_S = 19

#: (UTC instant from which it holds, TAI - UTC in s): IERS Bulletin C, every leap second since 1972.
LEAP_SECONDS: tuple[tuple[str, int], ...] = (
    ("1972-01-01", 10), ("1972-07-01", 11), ("1973-01-01", 12), ("1974-01-01", 13), ("1975-01-01", 14),
    ("1976-01-01", 15), ("1977-01-01", 16), ("1978-01-01", 17), ("1979-01-01", 18), ("1980-01-01", 19),
    ("1981-07-01", 20), ("1982-07-01", 21), ("1983-07-01", 22), ("1985-07-01", 23), ("1988-01-01", 24),
    ("1990-01-01", 25), ("1991-01-01", 26), ("1992-07-01", 27), ("1993-07-01", 28), ("1994-07-01", 29),
    ("1996-01-01", 30), ("1997-07-01", 31), ("1999-01-01", 32), ("2006-01-01", 33), ("2009-01-01", 34),
    ("2012-07-01", 35), ("2015-07-01", 36), ("2017-01-01", 37),
)  # fmt: skip

# Each row's start as UTC ns since the GPS epoch (UTC counted without leap seconds, as datetime64 does).
_LEAP_START_UTC_NS = np.array(
    [(np.datetime64(day, "ns") - GPS_EPOCH).astype(np.int64) for day, _ in LEAP_SECONDS], dtype=np.int64
)
_TAI_MINUS_UTC = np.array([n for _, n in LEAP_SECONDS], dtype=np.int64)
# The same starts on the GPS scale: a UTC instant u is GPS u + (TAI-UTC) - 19.
_LEAP_START_GPS_NS = _LEAP_START_UTC_NS + (_TAI_MINUS_UTC - TAI_MINUS_GPS_S) * NS_PER_S


def seconds_to_ns(seconds) -> np.ndarray:
    """Seconds (float or array) to int64 nanoseconds, rounded to the nearest ns."""
    return np.rint(np.asarray(seconds, dtype=np.float64) * NS_PER_S).astype(np.int64)


def datetime64_to_gps_ns(t) -> np.ndarray:
    """Calendar instants (``datetime64``, read as GPS time: no leap seconds applied) to int64 GPS ns."""
    return (np.asarray(t, dtype="datetime64[ns]") - GPS_EPOCH).astype("timedelta64[ns]").astype(np.int64)


def gps_ns_to_datetime64(gps_ns) -> np.ndarray:
    """int64 GPS ns to ``datetime64[ns]`` labels on the GPS scale (the inverse of :func:`datetime64_to_gps_ns`)."""
    return GPS_EPOCH + np.asarray(gps_ns, dtype=np.int64).astype("timedelta64[ns]")


def tai_minus_utc_s(utc) -> np.ndarray:
    """TAI - UTC (s, int) at UTC instants (``datetime64``), from :data:`LEAP_SECONDS`.

    Instants before 1972 are refused (UTC then had fractional, rate-offset steps).
    """
    utc_ns = datetime64_to_gps_ns(utc)
    i = np.searchsorted(_LEAP_START_UTC_NS, utc_ns, side="right") - 1
    if np.any(i < 0):
        raise InputError("UTC before 1972-01-01 has no integer leap-second count")
    return _TAI_MINUS_UTC[i]


def gps_minus_utc_s(gps_ns) -> np.ndarray:
    """GPS - UTC (s, int) at GPS instants (int64 ns): 0 at the GPS epoch, 18 since 2017-01-01."""
    gps_ns = np.asarray(gps_ns, dtype=np.int64)
    i = np.searchsorted(_LEAP_START_GPS_NS, gps_ns, side="right") - 1
    if np.any(i < 0):
        raise InputError("GPS time before 1972-01-01 has no integer leap-second count")
    return _TAI_MINUS_UTC[i] - TAI_MINUS_GPS_S


def utc_to_gps_ns(utc) -> np.ndarray:
    """UTC instants (``datetime64``) to int64 GPS ns (adds GPS - UTC)."""
    return datetime64_to_gps_ns(utc) + (tai_minus_utc_s(utc) - TAI_MINUS_GPS_S) * NS_PER_S


def gps_ns_to_utc(gps_ns) -> np.ndarray:
    """int64 GPS ns to UTC ``datetime64[ns]`` (subtracts GPS - UTC).

    A leap second itself (23:59:60 UTC) has no ``datetime64`` label; it maps onto the following
    00:00:00, as POSIX time does.
    """
    gps_ns = np.asarray(gps_ns, dtype=np.int64)
    return gps_ns_to_datetime64(gps_ns - gps_minus_utc_s(gps_ns) * NS_PER_S)


def week_tow(gps_ns) -> tuple[np.ndarray, np.ndarray]:
    """GPS week number (full, not modulo 1024) and time of week in int64 ns."""
    gps_ns = np.asarray(gps_ns, dtype=np.int64)
    week = np.floor_divide(gps_ns, NS_PER_WEEK)
    return week, gps_ns - week * NS_PER_WEEK


def gps_ns_from_week_tow(week, tow_ns) -> np.ndarray:
    """int64 GPS ns from a full GPS week and a time of week in int64 ns."""
    return np.asarray(week, dtype=np.int64) * NS_PER_WEEK + np.asarray(tow_ns, dtype=np.int64)


def resolve_week(week_mod, reference_gps_ns) -> np.ndarray:
    """The full GPS week whose value modulo 1024 is ``week_mod``, nearest the reference epoch's week.

    ``reference_gps_ns`` is a trusted epoch (the file's date, the host clock, a RINEX header). A receiver
    that reports weeks 1024 early (the 2019-04-07 rollover bug) is corrected by passing its raw week with
    a reference in the right era.
    """
    ref_week = np.floor_divide(np.asarray(reference_gps_ns, dtype=np.int64), NS_PER_WEEK)
    week_mod = np.mod(np.asarray(week_mod, dtype=np.int64), WEEK_ROLLOVER)
    k = np.rint((ref_week - week_mod) / WEEK_ROLLOVER).astype(np.int64)
    return week_mod + k * WEEK_ROLLOVER
