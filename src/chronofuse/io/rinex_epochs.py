"""RINEX observation and clock files as per-epoch receiver reports (:class:`chronofuse.epochs.ReceiverEpochs`).

* Observation files (RINEX 2.x/3.x, plain, gzip or Hatanaka, read by
  :func:`chronofuse.io.rinex_obs.read_any_observations`): one epoch per observation epoch, on GPS time
  (``TIME OF FIRST OBS`` scale GPS, as RINEX 2.11 section 5.2 makes the default; BDT is converted);
  ``n_sats`` counts the satellites with a pseudorange that epoch (blank and 0.000 are missing); the receiver reports no solution in RINEX, so ``fix_mode``
  is 0 (unknown) and the DOPs are absent; ``leap_s`` is the header's ``LEAP SECONDS`` when given, else
  the leap-second table.
* Clock files (RINEX clock 2.x/3.x, IGS/CODE products): ``AR`` records give each station receiver's
  clock bias (s) against the product's time scale at each epoch; every station is one receiver of the
  record on the union epoch grid (a station absent at an epoch has NaN there). The header's leap count
  is read as each version defines it (:func:`clock_header_leap`): ``LEAP SECONDS GNSS`` (3.04) is
  GNSS - UTC; ``LEAP SECONDS`` is GPS - UTC ("since 6-Jan-1980") up to 3.02 and TAI - UTC from 3.04 on
  (then GPS - UTC = TAI - UTC - 19 s); a value that disagrees with the leap-second table is still read as
  the format defines it, with a warning. georinex reads no clock
  files; the ``AR`` data line is fixed by the RINEX clock format (record type, name, epoch, value
  count, bias, sigma, separated by blanks), so it is split here.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from chronofuse.epochs import ReceiverEpochs
from chronofuse.io import rinex_text  # noqa: F401  (its exit hook releases the compress extension)
from chronofuse.io.formats import open_data, open_text
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_minus_utc_s
from chronofuse.validation import InputDataError

__all__ = ["rinex_kind", "read_rinex_observation_epochs", "read_rinex_clock_epochs", "clock_header_leap", "header_leap"]


def rinex_kind(path) -> tuple[str, str] | None:
    """(version, kind) from a RINEX header's first line (kind: ``obs``, ``nav`` or ``clock``), or None
    when the file is no RINEX file. A Hatanaka (Compact RINEX) file is an observation file: its first line
    ``CRINEX VERS / TYPE`` is followed by the RINEX header."""
    try:
        with open_data(path) as f:  # gzip told by content
            head = f.readline(200).decode("ascii", "replace")
            if "CRINEX VERS" in head:
                f.readline(200)
                head = f.readline(200).decode("ascii", "replace")
    except (OSError, EOFError):
        return None
    if "RINEX VERSION / TYPE" not in head:
        return None
    version = head[:9].strip()
    letter = head[9:40].strip()[:1].upper()  # column 21 in RINEX 2/3.0x, 22 in 3.04 clock files
    kind = {"O": "obs", "N": "nav", "G": "nav", "C": "clock"}.get(letter, "other")
    return version, kind


def _header_leap(path: Path) -> int | None:
    with open_text(path) as f:
        for line in f:
            if "LEAP SECONDS" in line[60:]:
                try:
                    return int(line[:6])
                except ValueError:
                    return None
            if "END OF HEADER" in line[60:]:
                return None
    return None


TAI_MINUS_GPS_S = 19


def clock_header_leap(path) -> int | None:
    """GPS - UTC (s) from a RINEX clock file's header, as its version defines its leap records (module
    docstring); None when the header gives none."""
    with open_text(path) as f:
        return header_leap(f)


def header_leap(lines) -> int | None:
    """GPS - UTC (s) from the header lines of a RINEX clock file (any iterable of lines, read up to ``END
    OF HEADER``): ``LEAP SECONDS GNSS`` as given; ``LEAP SECONDS`` as GPS - UTC before version 3.04 and as
    TAI - UTC from 3.04 on."""
    version, leap, gnss = 0.0, None, None
    for line in lines:
        label = line[60:].strip()
        try:
            if label.startswith("RINEX VERSION"):
                version = float(line[:9])
            elif label.startswith("LEAP SECONDS GNSS"):
                gnss = int(line[:6])
            elif label.startswith("LEAP SECONDS"):
                leap = int(line[:6])
        except ValueError:
            pass
        if label.startswith("END OF HEADER"):
            break
    if gnss is not None:
        return gnss
    if leap is None:
        return None
    return leap - TAI_MINUS_GPS_S if version >= 3.04 else leap


def read_rinex_observation_epochs(path) -> ReceiverEpochs:
    """The epochs of a RINEX observation file (see the module docstring). Raises
    :class:`InputDataError` naming the file when it cannot be read or has no epoch."""
    from chronofuse.io.rinex_obs import read_any_observations

    path = Path(path)
    obs = read_any_observations(path, observables=("C",))
    gps_ns = obs.gps_ns
    if obs.values:
        seen = np.zeros((gps_ns.size, len(obs.satellites)), dtype=bool)
        for v in obs.values.values():
            seen |= np.isfinite(v)
        n_sats = seen.sum(axis=1)
    else:
        n_sats = np.full(gps_ns.size, -1)
    order = np.argsort(gps_ns, kind="stable")
    gps_ns, n_sats = gps_ns[order], n_sats[order]
    keep = np.concatenate(([True], np.diff(gps_ns) > 0))
    gps_ns, n_sats = gps_ns[keep], n_sats[keep]
    leap = obs.header.leap_s
    leap_s = np.full(gps_ns.size, leap, dtype=np.int64) if leap is not None else gps_minus_utc_s(gps_ns)
    fields = ReceiverEpochs.absent(gps_ns, 1, 1, leap_s=leap_s[None, None, :])
    fields["n_sats"] = n_sats.astype(np.int16)[None, None, :]
    fields["time_valid"] = np.ones((1, 1, gps_ns.size), dtype=bool)
    return ReceiverEpochs(**fields)


def read_rinex_clock_epochs(path) -> tuple[tuple[str, ...], ReceiverEpochs, int]:
    """Station receivers' clock biases of a RINEX clock file: (station names, epochs of shape
    (1, stations, epochs), count of ``AR`` lines that could not be read). Raises :class:`InputDataError`
    naming the file when it holds no readable ``AR`` record."""
    path = Path(path)
    names: dict[str, int] = {}
    rows: list[tuple[int, str, float]] = []
    bad = 0
    in_header = True
    with open_text(path) as f:
        for line in f:
            if in_header:
                in_header = "END OF HEADER" not in line[60:]
                continue
            if not line.startswith("AR "):
                continue
            parts = line.split()
            try:
                stamp = np.datetime64(f"{int(parts[2]):04d}-{int(parts[3]):02d}-{int(parts[4]):02d}T"
                                      f"{int(parts[5]):02d}:{int(parts[6]):02d}:00", "ns")
                t = int(datetime64_to_gps_ns(stamp)) + int(round(float(parts[7]) * NS_PER_S))
                rows.append((t, parts[1], float(parts[9].replace("D", "E"))))
                names.setdefault(parts[1], len(names))
            except (IndexError, ValueError):
                bad += 1
    if not rows:
        raise InputDataError(f"no receiver clock (AR) record ({bad} unreadable)", str(path))
    times = np.unique(np.array([t for t, _, _ in rows], dtype=np.int64))
    bias = np.full((1, len(names), times.size), np.nan)
    idx_t = np.searchsorted(times, np.array([t for t, _, _ in rows], dtype=np.int64))
    idx_r = np.array([names[n] for _, n, _ in rows])
    bias[0, idx_r, idx_t] = [b for _, _, b in rows]
    leap = clock_header_leap(path)
    table = gps_minus_utc_s(times)
    if leap is not None and not np.all(table == leap):
        warnings.warn(f"{path}: the header's leap count gives GPS - UTC = {leap} s, the leap-second table "
                      f"{int(table[0])} s at the first epoch; read as the RINEX {rinex_kind(path)[0]} clock format "
                      "defines it", stacklevel=2)
    leap_s = leap if leap is not None else table[None, None, :]
    fields = ReceiverEpochs.absent(times, 1, len(names), leap_s=leap_s)
    fields["clock_bias_s"] = bias
    return tuple(names), ReceiverEpochs(**fields), bad
