"""RTKLIB's solution files: ``.pos`` (rnx2rtkp / rtkpost / rtknavi / str2str output) and its ``.stat``
solution status file, as clock and position series.

The layouts are RTKLIB's own (``solution.c``: ``outsolheads``/``outsols``; ``rtkpos.c``: ``outsolstat``,
version 2.4.3):

* ``.pos``: ``%`` header lines, the last of which names the columns; each row the epoch (``yyyy/mm/dd
  hh:mm:ss.sss``, or ``week tow`` with ``out-timeform=tow``) in the time system the header names (``GPST``,
  ``UTC`` or ``JST``), then latitude, longitude (deg) and height (m) (``out-solformat=llh``), or x, y, z
  ECEF (m) (``xyz``), then ``Q`` (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP) and ``ns`` (satellites).
  A position series (no clock): columns ``lat_deg``, ``lon_deg``, ``height_m`` or ``x_m``, ``y_m``, ``z_m``,
  ``quality``, ``n_sats``; ``ok`` where a solution exists (Q 1..6).
* ``.stat`` (``out-outstat=state``): ``$POS,week,tow,stat,x,y,z,xf,yf,zf`` (ECEF, m) and
  ``$CLK,week,tow,stat,rcv,clk1,clk2,clk3,clk4``: the receiver clock bias against GPS time (ns, positive:
  the receiver clock is ahead, ``sol.dtr[0]``) and its offsets for the other systems (ns). One series,
  ``rtklib``: phase ``clock_bias_s`` (clk1 x 1e-9), ``isb2_s``..``isb4_s``, the ``$POS`` coordinates on the
  same epochs, ``quality``; ``ok`` where stat is 1..6. Other ``$`` lines (``$VELACC``, ``$ION``, ``$SAT``...)
  are counted in a note.

Times in GPST are on the ``gps`` scale (ns since 1980-01-06; ``week * 604800 + tow``: RTKLIB writes the
first epoch of a week as the previous week's tow 604800, which is the same instant); UTC times on
``unix-utc``. A row that is not of the header's layout is an error naming its line.
"""

from __future__ import annotations

import calendar
from pathlib import Path

from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.io.formats import open_text
from chronofuse.validation import InputDataError

__all__ = ["read_rtklib", "QUALITY"]

#: RTKLIB's solution quality flags (``solution.c``: SOLQ_*).
QUALITY = {0: "none", 1: "fix", 2: "float", 3: "sbas", 4: "dgps", 5: "single", 6: "ppp", 7: "dr"}
GPS_EPOCH_UNIX_S = 315_964_800
_WEEK_NS = 604_800 * 1_000_000_000


def _seconds_ns(text: str) -> int:
    whole, _, frac = text.partition(".")
    sign = -1 if whole.startswith("-") else 1
    return sign * (abs(int(whole)) * 1_000_000_000 + int((frac + "000000000")[:9]))


def _week_tow_ns(week: str, tow: str) -> int:
    return int(week) * _WEEK_NS + _seconds_ns(tow)


def _date_ns(date: str, time: str) -> int:
    """ns since 1970 of ``yyyy/mm/dd hh:mm:ss.sss`` read as a calendar date on its own scale."""
    y, mo, d = (int(x) for x in date.split("/"))
    hms, _, frac = time.partition(".")
    h, mi, s = (int(x) for x in hms.split(":"))
    return calendar.timegm((y, mo, d, h, mi, s, 0, 0, 0)) * 1_000_000_000 + int((frac + "000000000")[:9])


def read_rtklib(path: str | Path) -> list[LogSeries]:
    """The series of an RTKLIB ``.pos`` or ``.stat`` file (told by its content; plain or gzip)."""
    path = Path(path)
    with open_text(path) as fh:
        lines = fh.read().splitlines()
    if any(line.startswith("$") for line in lines[:50]):
        return [_read_stat(lines, str(path))]
    return [_read_pos(lines, str(path))]


def _read_stat(lines: list[str], source: str) -> LogSeries:
    rows: dict[int, dict] = {}
    order, other = [], 0
    for lineno, line in enumerate(lines, start=1):
        if not line.startswith(("$CLK,", "$POS,")):
            other += bool(line.strip())
            continue
        f = line.split(",")
        try:
            t_ns = _week_tow_ns(f[1], f[2])
            stat = int(f[3])
            if f[0] == "$CLK":
                vals = {"clock_bias_s": float(f[5]) * 1e-9, "isb2_s": float(f[6]) * 1e-9,
                        "isb3_s": float(f[7]) * 1e-9, "isb4_s": float(f[8]) * 1e-9}
            else:
                vals = {"x_m": float(f[4]), "y_m": float(f[5]), "z_m": float(f[6])}
        except (IndexError, ValueError, OverflowError):
            raise InputDataError(f"not an RTKLIB {f[0]} line ({len(f)} fields)", source, lineno) from None
        row = rows.get(t_ns)
        if row is None:
            row = rows[t_ns] = {"line": lineno, "quality": stat}
            order.append(t_ns)
        row.update(vals)
    clocked = [t for t in order if "clock_bias_s" in rows[t]]
    if not clocked:
        raise InputDataError("an RTKLIB status file without a $CLK line (out-outstat=state writes them)", source)
    names = ("clock_bias_s", "isb2_s", "isb3_s", "isb4_s", "x_m", "y_m", "z_m", "quality")
    cols = {n: [rows[t].get(n, float("nan")) for t in clocked] for n in names}
    kinds = {n: "other" for n in names}
    kinds["clock_bias_s"] = "phase"
    notes = ["RTKLIB solution status ($CLK receiver clock bias against GPS time in ns, positive: receiver "
             "clock ahead; $POS ECEF in m)"]
    if other:
        notes.append(f"{other} other lines ($VELACC, $ION, $SAT, ...) are not clock samples")
    quality = cols["quality"]
    return log_series(clocked, cols, kinds, [rows[t]["line"] for t in clocked], clock="rtklib", time_scale="gps",
                      fmt="rtklib-stat", source=source, phase="clock_bias_s",
                      ok=[1 <= q <= 6 for q in quality], notes=notes)


def _read_pos(lines: list[str], source: str) -> LogSeries:
    header = [line for line in lines if line.startswith("%")]
    names_line = next((line for line in reversed(header) if "Q" in line.split()), None)
    if names_line is None:
        raise InputDataError("an RTKLIB .pos file without its column header line (out-outhead=on writes it)",
                             source)
    heads = names_line.lstrip("%").split()
    system = heads[0]
    if system not in ("GPST", "UTC", "JST"):
        raise InputDataError(f"time system {system!r}: RTKLIB writes GPST, UTC or JST", source)
    llh = "latitude(deg)" in heads
    ecef = "x-ecef(m)" in heads
    if not (llh or ecef):
        raise InputDataError("only llh and xyz RTKLIB solutions are read (out-solformat=llh or xyz)", source)
    pos_names = ("lat_deg", "lon_deg", "height_m") if llh else ("x_m", "y_m", "z_m")
    cols = {n: [] for n in (*pos_names, "quality", "n_sats")}
    t, line_nos = [], []
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or line.startswith("%"):
            continue
        f = line.split()
        try:
            if len(f) < 7:
                raise ValueError
            if "/" in f[0]:
                t_ns = _date_ns(f[0], f[1])
                if system == "GPST":
                    t_ns -= GPS_EPOCH_UNIX_S * 1_000_000_000
                elif system == "JST":
                    t_ns -= 9 * 3600 * 1_000_000_000
            else:
                t_ns = _week_tow_ns(f[0], f[1])
            values = [float(x) for x in f[2:7]]
        except (IndexError, ValueError, OverflowError):
            raise InputDataError(f"not a row of this RTKLIB .pos layout ({len(f)} fields)", source, lineno) from None
        t.append(t_ns)
        line_nos.append(lineno)
        for n, v in zip(cols, values):
            cols[n].append(v)
    kinds = {n: "other" for n in cols}
    scale = "gps" if system == "GPST" else "unix-utc"
    notes = [f"RTKLIB .pos solution in {system}; a position series: no receiver clock (the .stat file's $CLK "
             "lines carry it)"]
    return log_series(t, cols, kinds, line_nos, clock="rtklib position", time_scale=scale, fmt="rtklib-pos",
                      source=source, ok=[1 <= q <= 6 for q in cols["quality"]], notes=notes)
