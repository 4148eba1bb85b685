"""``chronofuse inspect`` on a 100 MB NMEA and a 100 MB UBX recording against the bare parser libraries
(pynmeagps' NMEAReader, pyubx2's UBXReader) reading the same bytes, timed in the same process.

The recordings are built in a temporary folder by repeating real captures of gpsd's regression set
(NMEA: five multi-constellation NMEA receivers; UBX: a timing M8T with TIM-TP/NAV-TIMELS, an F9P with
NAV-CLOCK + RXM-RAWX, an M8 with NAV-SAT, a NAV-CLOCK receiver). "ours" is the library call behind the
command (``read_capture`` + ``summarize``: framing with checksums, decoding, epochs, the summary);
"baseline" iterates the library's reader over the file with its default checksum validation. Target:
ours costs at most 1.3x the baseline (ratio = baseline_s / ours_s >= 1/1.3). MB/s of both are in the
note. ``quick`` uses 4 MB recordings.

Run alone: ``.venv/bin/python benchmarks/bench_readers.py [--quick] [--mb N] [--only NMEA|UBX]``.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from pynmeagps import NMEAReader
from pyubx2 import ERR_IGNORE, NMEA_PROTOCOL, UBX_PROTOCOL, UBXReader

from chronofuse.io.inspect import read_capture, summarize

_NMEA_SOURCES = ("telit-he910.log", "skytraq-dgps.log", "ublox-8.log", "quectel-l76k-dual.log", "bundg_zeus_9.log")
_UBX_SOURCES = ("u-blox-m8t-time.log", "ublox-zed-f9p_hpg1.11.log", "ublox-glo.log", "navisys-gr701w.log")
TARGET_RATIO = 1 / 1.3


def _gpsd_dir() -> Path:
    candidates = [Path(__file__).resolve().parents[1] / "tests" / "data" / "receivers" / "gpsd"]
    if "CHRONOFUSE_DATA" in os.environ:
        candidates.append(Path(os.environ["CHRONOFUSE_DATA"]) / "receivers" / "gpsd")
    candidates.append(Path(__file__).resolve().parents[2] / "shared" / "data" / "receivers" / "gpsd")
    candidates.append(Path(__file__).resolve().parents[3] / "shared" / "data" / "receivers" / "gpsd")
    for path in candidates:
        if path.is_dir():
            return path
    raise RuntimeError("gpsd captures not found; set CHRONOFUSE_DATA")


def build_recording(folder: Path, name: str, sources, size_bytes: int) -> Path:
    """Write ``name`` in ``folder``: the sources concatenated and repeated until ``size_bytes``."""
    block = b"".join((_gpsd_dir() / s).read_bytes() for s in sources)
    path = folder / name
    with path.open("wb") as out:
        written = 0
        while written < size_bytes:
            out.write(block)
            written += len(block)
    return path


def bare_nmea(path: Path) -> int:
    with path.open("rb") as stream:
        return sum(1 for _ in NMEAReader(stream, quitonerror=ERR_IGNORE))


def bare_ubx(path: Path) -> int:
    with path.open("rb") as stream:
        return sum(1 for _ in UBXReader(stream, protfilter=UBX_PROTOCOL | NMEA_PROTOCOL, quitonerror=ERR_IGNORE))


def ours(path: Path) -> dict:
    return summarize(read_capture(path))


def _timed(fn, path):
    start = time.perf_counter()
    out = fn(path)
    return time.perf_counter() - start, out


def run(quick: bool = False, mb: float | None = None, only: str | None = None) -> list[dict]:
    """One row per recording kind (``only``: "NMEA" or "UBX" for one of them)."""
    size = int((mb if mb is not None else (4 if quick else 100)) * 1e6)
    rows = []
    cases = (("NMEA", _NMEA_SOURCES, bare_nmea, "pynmeagps NMEAReader"),
             ("UBX", _UBX_SOURCES, bare_ubx, "pyubx2 UBXReader"))
    with tempfile.TemporaryDirectory() as tmp:
        for label, sources, bare, baseline in cases:
            if only is not None and label != only.upper():
                continue
            path = build_recording(Path(tmp), f"rec.{label.lower()}", sources, size)
            megabytes = path.stat().st_size / 1e6
            base_s, n_messages = _timed(bare, path)
            ours_s, doc = _timed(ours, path)
            ratio = base_s / ours_s
            rows.append({
                "name": f"inspect {label} {megabytes:.0f} MB",
                "ours_s": ours_s,
                "baseline": baseline,
                "baseline_s": base_s,
                "ratio": ratio,
                "target": f">= {TARGET_RATIO:.2f} (ours <= 1.3x the library)",
                "passed": ratio >= TARGET_RATIO,
                "note": (f"ours {megabytes / ours_s:.2f} MB/s, library {megabytes / base_s:.2f} MB/s; "
                         f"{n_messages:,} messages by the library, {doc['epochs']:,} epochs by ours"),
            })
            path.unlink()
    return rows


if __name__ == "__main__":  # pragma: no cover
    quick = "--quick" in sys.argv
    mb = float(sys.argv[sys.argv.index("--mb") + 1]) if "--mb" in sys.argv else None
    only = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv else None
    for row in run(quick=quick, mb=mb, only=only):
        print(row)
