"""Why gpsd's SKY DOPs differ from ours: each disagreeing value is tested against concrete hypotheses, and
given the first that reproduces gpsd's value within :data:`TOLERANCE` (else :data:`UNEXPLAINED`).

Used by ``test_gpsd_oracle.py``; ``python tests/io/gpsd_dop_reasons.py`` prints the breakdown over every
capture of the oracle (the figures in ``docs/receivers.md``).
"""

from __future__ import annotations

import math
import re
from collections import Counter
from pathlib import Path

import numpy as np

from chronofuse.io.dop import dop_cofactor

TOLERANCE = 0.005

NEXT_BURST = "next_burst"
LATER_EPOCH = "later_epoch"
PREVIOUS_BURST = "previous_burst"
OTHER_MESSAGE = "other_message_same_burst"
REPLACED_IN_CYCLE = "replaced_in_cycle"
GPSD_GEOMETRY = "gpsd_geometry"
UNEXPLAINED = "unexplained"

#: reason -> what it means (each is checked value by value by :func:`classify`)
REASONS = {
    NEXT_BURST: "gpsd's value is the receiver's own DOP of the NEXT epoch: gpsd's last SKY with this time went "
                "out after the next epoch's first DOP message (an NMEA GSA, a UBX NAV-DOP) and before the message "
                "that moves gpsd's time on; ours is the DOP sent with this epoch",
    LATER_EPOCH: "gpsd's value is the receiver's DOP of a later epoch, before gpsd's next SKY time: gpsd's time "
                 "stood still over several of our epochs and it kept reporting their DOPs under this time",
    PREVIOUS_BURST: "gpsd's value is the receiver's DOP of an EARLIER epoch, back to gpsd's previous SKY time: this "
                    "epoch's DOP message came after gpsd's last report for it",
    OTHER_MESSAGE: "gpsd's value is another DOP message of the same burst: a later GSA (we take the first GSA of "
                   "a burst) or, for HDOP, the GGA's HDOP",
    GPSD_GEOMETRY: "gpsd's value is the DOP recomputed from the elevation/azimuth of the satellites its SKY marks "
                   "used (gpsd's own fill_dop), not the receiver's value",
    REPLACED_IN_CYCLE: "gpsd reported our value in an earlier SKY of this epoch, then a later message of the same "
                       "cycle changed it; the last SKY of the epoch is the one compared",
    UNEXPLAINED: "no hypothesis above reproduces gpsd's value",
}

_TIMED = re.compile(rb"^\$(?:GP|GN|GL|GA|GB|BD|GQ|GI)(GGA|RMC|ZDA|GNS|GLL|GST),([^,*]*)")
_GSA = re.compile(rb"^\$(?:GP|GN|GL|GA|GB|BD|GQ|GI)GSA,(.*)\*")
_GGA = re.compile(rb"^\$(?:GP|GN|GL|GA|GB|BD|GQ|GI)GGA,(.*)\*")


def _float(text: bytes) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _tod_key(field: bytes) -> str | None:
    """``hhmmss(.sss)`` -> ``"hh:mm:ss.sss"`` (gpsd's label format), None when empty or malformed."""
    m = re.fullmatch(rb"(\d\d)(\d\d)(\d\d)(?:\.(\d+))?", field)
    if not m:
        return None
    frac = (m.group(4) or b"0").decode()[:3].ljust(3, "0")
    return f"{m.group(1).decode()}:{m.group(2).decode()}:{m.group(3).decode()}.{frac}"


def burst_dops(log: Path) -> dict[str, list[dict]]:
    """Every DOP message of each NMEA burst, in order, keyed by the burst's time of day (``hh:mm:ss.sss``):
    ``{"pdop", "hdop", "vdop"}`` of each GSA and ``{"hdop"}`` of each GGA. A second, line-level reading of the
    capture (independent of :mod:`chronofuse.io.nmea`): a sentence without a time belongs to the burst of the
    last timed sentence."""
    out: dict[str, list[dict]] = {}
    current = None
    for line in log.read_bytes().splitlines():
        start = line.find(b"$")
        if start < 0:
            continue
        line = line[start:]
        m = _TIMED.match(line)
        if m:
            key = _tod_key(m.group(2))
            if key is not None:
                current = key
        if current is None:
            continue
        g = _GSA.match(line)
        if g:
            f = g.group(1).split(b",")
            if len(f) >= 17:
                out.setdefault(current, []).append(
                    {"pdop": _float(f[14]), "hdop": _float(f[15]), "vdop": _float(f[16])})
        elif m and m.group(1) == b"GGA":
            f = _GGA.match(line)
            parts = f.group(1).split(b",") if f else []
            if len(parts) > 7:
                out.setdefault(current, []).append({"hdop": _float(parts[7])})
    return out


def sky_geometry_dops(satellites: list[dict]) -> dict[str, float]:
    """gpsd's fill_dop: DOPs of the satellites marked used, from their elevation/azimuth (one clock), the
    diagonal of :func:`chronofuse.io.dop.dop_cofactor`."""
    used = [(s["el"], s["az"]) for s in satellites if s.get("used") and "el" in s and "az" in s]
    g = dop_cofactor(used)
    if g is None:
        return {}
    d = np.abs(np.diag(g))
    return {"gdop": math.sqrt(d.sum()), "pdop": math.sqrt(d[:3].sum()), "hdop": math.sqrt(d[:2].sum()),
            "vdop": math.sqrt(d[2]), "tdop": math.sqrt(d[3])}


def _near(a, b) -> bool:
    return a is not None and b is not None and np.isfinite(a) and np.isfinite(b) and abs(a - b) <= TOLERANCE


def classify(name: str, gpsd: float, ours: np.ndarray, i: int, skies: list[dict], bursts: list[dict],
             window: tuple[int, int] | None = None) -> str:
    """The first reason (in the order of :data:`REASONS`) that reproduces gpsd's value of DOP ``name`` at
    our epoch ``i``. ``ours``: our column of that DOP; ``skies``: gpsd's SKY reports of this epoch in order
    (the last is the one compared); ``bursts``: the burst's DOP messages (:func:`burst_dops`); ``window``:
    our epochs of gpsd's previous and next SKY times (``(i - 1, i + 1)`` when not given): the epochs whose
    DOP gpsd may have reported under this time."""
    before, after = window if window is not None else (i - 1, i + 1)
    if i + 1 < ours.size and _near(float(ours[i + 1]), gpsd):
        return NEXT_BURST
    if any(_near(float(v), gpsd) for v in ours[i + 2:after + 1]):
        return LATER_EPOCH
    earlier = ours[max(min(before, i - 1), 0):i]
    if any(_near(float(v), gpsd) for v in earlier):
        return PREVIOUS_BURST
    if any(_near(m.get(name), gpsd) for m in bursts):
        return OTHER_MESSAGE
    for sky in reversed(skies):
        if sky.get("satellites"):
            if _near(sky_geometry_dops(sky["satellites"]).get(name), gpsd):
                return GPSD_GEOMETRY
            break
    if any(_near(s.get(name), float(ours[i])) for s in skies[:-1]):
        return REPLACED_IN_CYCLE
    return UNEXPLAINED


def _summary() -> None:
    import sys

    root = Path(__file__).resolve().parents[1]
    sys.path[:0] = [str(root.parent), str(root)]
    from tests.io.test_gpsd_oracle import ORACLE_FILES, compare_with_gpsd
    from _helpers import receivers_dir

    total, sums, files, decoded = Counter(), Counter(), 0, 0
    for name in ORACLE_FILES:
        result = compare_with_gpsd(receivers_dir() / "gpsd" / name)
        if not result["protocols"]:
            continue
        decoded += 1
        sums.update({key: result[key] for key in ("gpsd_epochs", "missing", "mode", "dop_compared")})
        total.update(result["dop_reasons"])
        files += bool(result["dop_reasons"])
    print(f"{len(ORACLE_FILES)} captures, {decoded} with NMEA/UBX we decode: {sums['gpsd_epochs']} gpsd epochs, "
          f"{sums['missing']} not ours, {sums['mode']} fix-mode disagreements")
    print(f"{sum(total.values())} of {sums['dop_compared']} DOP values differ, in {files} files:")
    for reason, n in total.most_common():
        print(f"  {reason}: {n}")

if __name__ == "__main__":
    _summary()
