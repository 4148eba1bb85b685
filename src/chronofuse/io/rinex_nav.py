"""Multi-GNSS broadcast navigation files (RINEX 3.0x and 4.0x, plain / gz): GPS, Galileo, BeiDou and QZSS
ephemerides.

Record layouts (RINEX 3.05, Tables A6 GPS, A8 Galileo, A14 BeiDou, A10 QZSS): a first line
``Snn yyyy mm dd hh mm ss`` (the clock reference time ``toc`` on the system's own time scale) with
``af0 af1 af2``, then seven lines of four 19-character ``D19.12`` fields from column 5. The broadcast orbit
lines are the same for the four Keplerian systems except where the table says otherwise:

====  ====================  =====================  ========================  ===================
line  GPS / QZSS            Galileo                BeiDou                    (fields 1-4)
====  ====================  =====================  ========================  ===================
1     IODE Crs dn M0        IODnav Crs dn M0       AODE Crs dn M0
2     Cuc e Cus sqrtA       same                   same
3     toe Cic OMEGA0 Cis    same                   same (toe in BDT)
4     i0 Crc omega OMDOT    same                   same
5     IDOT L2codes week -   IDOT sources week -    IDOT - BDTweek -
6     URA health TGD IODC   SISA health BGDa BGDb  URA SatH1 TGD1 TGD2
7     ttm fit               ttm                    ttm AODC
====  ====================  =====================  ========================  ===================

GLONASS and SBAS records (4 lines) and NavIC are skipped here (counted in ``skipped``).

Time scales: GPS time for GPS, Galileo (GST is steered to GPS weeks, RINEX writes its week continuous with
GPS) and QZSS; BDT for BeiDou: ``BDT = GPST - 14 s`` and BDT week 0 began at 2006-01-01 (GPS week 1356)
(BeiDou ICD B1I 3.0, 5.2.3.x). Every record's ``toc`` and ``toe`` are also kept as GPS-time int64 ns.

Group delay applied by a single-frequency user of the code read here: GPS L1 C/A ``TGD`` (IS-GPS-200
20.3.3.3.3.2), Galileo E1 ``BGD(E1, E5a)`` (Galileo OS SIS ICD 5.1.5, as RTKLIB's single-frequency
positioning uses), BeiDou B1I ``TGD1`` (BDS ICD B1I 5.2.4.10: ``dt_B1I = dt_sv - TGD1``).

The broadcast Klobuchar coefficients of the header (``IONOSPHERIC CORR`` ``GPSA``/``GPSB``) serve every
system, scaled to each frequency (as RTKLIB does); the BeiDou ones (``BDSA``/``BDSB``) and Galileo's NeQuick
``GAL`` are kept too.

RINEX 4 (4.00, section 5.4 and Tables A30-A33): each record opens with a ``> EPH Snn TYPE`` line; the orbit
records read are GPS and QZSS ``LNAV``, Galileo ``INAV``/``FNAV`` and BeiDou ``D1``/``D2`` (the layouts
above); any other message (CNAV, CNV1-3, GLONASS, SBAS, NavIC) is skipped whole and counted. The ionosphere
moves from the header into ``> ION Snn TYPE`` records: ``G.. LNAV`` (and ``J.. LNAV``) and ``C.. D1D2``
carry Klobuchar ``alpha0..3, beta0..3`` (a first line ``    yyyy mm dd hh mm ss`` with three ``D19.12``
fields from column 24, then four, then ``beta3`` and a region code), ``E.. IFNV`` NeQuick ``ai0..2``. The
first record of each kind serves the whole file (as the header's coefficients do); ``STO`` and ``EOP``
records are skipped.

RINEX 2 navigation files (GPS only) are read by :func:`chronofuse.io.rinex.read_gps_navigation` (georinex).
"""

from __future__ import annotations

import numpy as np

from chronofuse.gnss.ephemeris import GpsNavigation
from chronofuse.gnss.systems import SYSTEM_CONSTANTS
from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_ns_from_week_tow, seconds_to_ns
from chronofuse.validation import InputDataError

__all__ = ["read_navigation", "merge_navigation", "frequency_scale"]

_KEPLER = ("G", "E", "C", "J")
_LINES = {"G": 8, "E": 8, "C": 8, "J": 8, "I": 8, "R": 4, "S": 4}
#: RINEX 4 orbit messages read, per system (others are skipped whole).
_EPH4 = {"G": ("LNAV",), "J": ("LNAV",), "E": ("INAV", "FNAV"), "C": ("D1", "D2")}
#: RINEX 4 ION records kept: (system, message) -> the header label of the same coefficients.
_ION4 = {("G", "LNAV"): ("GPSA", "GPSB"), ("J", "LNAV"): ("QZSA", "QZSB"), ("C", "D1D2"): ("BDSA", "BDSB"),
         ("E", "IFNV"): ("GAL", None)}
_BDT_WEEK0_GPS = 1356
_BDT_LAG_NS = 14 * NS_PER_S

# (line, field) -> name for the orbit lines, per system; line 0 fields 1..3 are af0, af1, af2.
_COMMON = {(1, 1): "crs_m", (1, 2): "delta_n_rad_per_s", (1, 3): "m0_rad", (2, 0): "cuc_rad", (2, 1): "eccentricity",
           (2, 2): "cus_rad", (2, 3): "sqrt_a_sqrt_m", (3, 0): "toe_s", (3, 1): "cic_rad", (3, 2): "omega0_rad",
           (3, 3): "cis_rad", (4, 0): "i0_rad", (4, 1): "crc_m", (4, 2): "omega_rad", (4, 3): "omega_dot_rad_per_s",
           (5, 0): "idot_rad_per_s", (5, 2): "week"}
_GROUP_DELAY = {"G": (6, 2), "J": (6, 2), "E": (6, 2), "C": (6, 2)}  # TGD, BGD(E1,E5a), TGD1
_HEALTH = {"G": (6, 1), "J": (6, 1), "E": (6, 1), "C": (6, 1)}


def _number(text: str) -> float:
    text = text.strip().replace("D", "E").replace("d", "e")
    return float(text) if text else 0.0


def _fields(line: str, first: bool) -> list[float]:
    start = 23 if first else 4
    return [_number(line[start + 19 * k:start + 19 * (k + 1)]) for k in range(3 if first else 4)]


def _header(lines: list[str], source: str):
    first = lines[0] if lines else ""
    if "RINEX VERSION / TYPE" not in first or first[20:21].upper() not in ("N", "G"):
        raise InputDataError("not a RINEX navigation file (no 'N' in the RINEX VERSION / TYPE line)", source)
    try:
        version = float(first[:9])
    except ValueError:
        raise InputDataError("unreadable RINEX version in the first line", source) from None
    iono: dict[str, list[float]] = {}
    for i, line in enumerate(lines):
        label = line[60:].strip()
        if label == "END OF HEADER":
            return version, iono, i + 1
        if label == "IONOSPHERIC CORR":
            kind = line[:4].strip()
            try:
                iono[kind] = [_number(line[5 + 12 * k:5 + 12 * (k + 1)]) for k in range(4)]
            except ValueError:
                continue
    raise InputDataError("no END OF HEADER line", source)


def _ion_record(block: list[str], key, iono: dict, source: str, line_no: int) -> None:
    """The coefficients of one RINEX 4 ``> ION`` record (``block``: its lines after the ``>`` line) into
    ``iono`` under the header's labels, unless the header or an earlier record gave them."""
    alpha_label, beta_label = key
    if alpha_label in iono or not block:
        return
    try:
        values = _fields(block[0], True) + [v for b in block[1:] for v in _fields(b, False)]
    except ValueError as exc:
        raise InputDataError(f"line {line_no}: ION record not readable ({exc})", source) from None
    if beta_label is None:
        iono[alpha_label] = values[:3]
    elif len(values) >= 8:
        iono[alpha_label], iono[beta_label] = values[:4], values[4:8]
    else:
        raise InputDataError(f"line {line_no}: ION record cut short ({len(values)} of 8 Klobuchar values)", source)


def _coefficients(iono: dict, label: str) -> np.ndarray | None:
    return np.asarray(iono[label], dtype=np.float64) if label in iono else None


def read_navigation(path, *, systems=None) -> GpsNavigation:
    """Broadcast ephemerides of a RINEX 3 navigation file (module docstring): every GPS, Galileo, BeiDou and
    QZSS record (``systems``: the letters to keep, None all four).

    Returns a :class:`chronofuse.gnss.ephemeris.GpsNavigation` whose ``params`` carry, besides the
    IS-GPS-200 fields, ``group_delay_s`` (the delay the single-frequency user removes), ``gm_m3_per_s2``,
    ``omega_e_rad_per_s``, ``accuracy_m`` (the broadcast URA or SISA) and ``geo`` (1.0 for a BeiDou GEO); ``toe_gps_ns`` holds each ``toe`` on GPS time. Raises
    :class:`InputDataError` naming the file (and the line) when it is not a RINEX 3 navigation file or a
    record is damaged, or it holds no record of the systems asked for.
    """
    source = str(path)
    lines = rinex_bytes(path).decode("ascii", "replace").splitlines()
    version, iono, body = _header(lines, source)
    if version < 3.0:
        from chronofuse.io.rinex import read_gps_navigation

        return read_gps_navigation(path)
    keep = set(_KEPLER if systems is None else systems) & set(_KEPLER)
    rows: list[dict] = []
    names: list[str] = []
    tocs: list[int] = []
    skipped = 0
    i, n = body, len(lines)
    while i < n:
        line = lines[i]
        if line.startswith(">"):  # RINEX 4: a record's type line
            kind, sat, message = (line[1:].split() + ["", "", ""])[:3]
            end = i + 1
            while end < n and not lines[end].startswith(">"):
                end += 1
            if kind == "EPH" and sat[:1] in keep and message in _EPH4.get(sat[:1], ()):
                i += 1  # the record itself, read below
                continue
            if kind == "EPH":
                skipped += 1
            elif kind == "ION" and (sat[:1], message) in _ION4:
                _ion_record(lines[i + 1:end], _ION4[(sat[:1], message)], iono, source, i + 2)
            i = end
            continue
        letter = line[:1]
        if letter not in _LINES or not line[1:3].strip().isdigit():
            i += 1
            continue
        count = _LINES[letter]
        if letter not in keep:
            skipped += 1
            i += count
            continue
        block = lines[i:i + count]
        if len(block) < count:
            raise InputDataError(f"line {i + 1}: {line[:3]} record cut short", source)
        try:
            y, mo, d, h, mi, s = (int(v) for v in line[3:23].split())
            values = [_fields(block[0], True)] + [_fields(b, False) for b in block[1:]]
        except ValueError as exc:
            raise InputDataError(f"line {i + 1}: {line[:3]} record not readable ({exc})", source) from None
        stamp = np.datetime64(f"{y:04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}:{s:02d}", "ns")
        toc = int(datetime64_to_gps_ns(np.array([stamp]))[0]) + (_BDT_LAG_NS if letter == "C" else 0)
        rec = {"af0_s": values[0][0], "af1_s_per_s": values[0][1], "af2_s_per_s2": values[0][2]}
        rec.update({name: values[line_no][k] for (line_no, k), name in _COMMON.items()})
        rec["health"] = values[_HEALTH[letter][0]][_HEALTH[letter][1]]
        rec["group_delay_s"] = values[_GROUP_DELAY[letter][0]][_GROUP_DELAY[letter][1]]
        rec["tgd_s"] = rec["group_delay_s"]
        rec["accuracy_m"] = values[6][0]  # URA (GPS, QZSS, BDS) or SISA (Galileo), metres
        week = int(rec["week"])
        if letter == "C":
            toe_ns = gps_ns_from_week_tow(np.int64(week + _BDT_WEEK0_GPS), seconds_to_ns(rec["toe_s"])) + _BDT_LAG_NS
        else:
            toe_ns = gps_ns_from_week_tow(np.int64(week), seconds_to_ns(rec["toe_s"]))
        const = SYSTEM_CONSTANTS[letter]
        rec["gm_m3_per_s2"] = const.gm_m3_per_s2
        rec["omega_e_rad_per_s"] = const.omega_e_rad_per_s
        prn = int(line[1:3])
        rec["geo"] = 1.0 if letter == "C" and (prn <= 5 or prn >= 59) else 0.0
        rec["_toe_ns"] = int(toe_ns)  # int64 ns, kept out of the float params
        rows.append(rec)
        names.append(f"{letter}{prn:02d}")
        tocs.append(toc)
        i += count
    if not rows:
        raise InputDataError(f"no {'/'.join(sorted(keep))} ephemeris record in the file", source)
    params = {k: np.array([r[k] for r in rows], dtype=np.float64) for k in rows[0] if k != "_toe_ns"}
    return GpsNavigation(satellites=names, toc_gps_ns=np.asarray(tocs, dtype=np.int64), params=params,
                         klobuchar_alpha=_coefficients(iono, "GPSA"), klobuchar_beta=_coefficients(iono, "GPSB"),
                         source=source, toe_gps_ns=np.array([r["_toe_ns"] for r in rows], dtype=np.int64),
                         n_skipped_records=skipped, bds_klobuchar_alpha=_coefficients(iono, "BDSA"),
                         bds_klobuchar_beta=_coefficients(iono, "BDSB"), nequick_gal=_coefficients(iono, "GAL"))


def merge_navigation(navs) -> GpsNavigation:
    """One navigation record set from several files (e.g. the GN, EN and CN files of one day): records
    concatenated; the first file's ionosphere coefficients that exist are kept, per kind."""
    navs = list(navs)
    if len(navs) == 1:
        return navs[0]
    keys = set.intersection(*(set(n.params) for n in navs))
    first = lambda name: next((getattr(n, name) for n in navs if getattr(n, name) is not None), None)  # noqa: E731
    toe = [n.toe_gps_ns if n.toe_gps_ns is not None else n.toe_from_week() for n in navs]
    return GpsNavigation(satellites=[s for n in navs for s in n.satellites],
                         toc_gps_ns=np.concatenate([n.toc_gps_ns for n in navs]),
                         params={k: np.concatenate([n.params[k] for n in navs]) for k in sorted(keys)},
                         klobuchar_alpha=first("klobuchar_alpha"), klobuchar_beta=first("klobuchar_beta"),
                         source=" + ".join(n.source for n in navs), toe_gps_ns=np.concatenate(toe),
                         n_skipped_records=sum(n.n_skipped_records for n in navs),
                         bds_klobuchar_alpha=first("bds_klobuchar_alpha"), bds_klobuchar_beta=first("bds_klobuchar_beta"),
                         nequick_gal=first("nequick_gal"))


def frequency_scale(letter: str) -> float:
    """``(f_L1 / f)^2`` for the code read of system ``letter``: the Klobuchar (L1) delay scaled to it."""
    return (SYSTEM_CONSTANTS["G"].frequency_hz / SYSTEM_CONSTANTS[letter].frequency_hz) ** 2

