"""RTKLIB's ``rnx2rtkp`` (Debian package ``rtklib``, 2.4.3 b34) as an independent single-point solution.

Run on the same files with the options that match :mod:`chronofuse.gnss.point_positioning`: single mode,
L1, elevation mask, broadcast ephemeris, broadcast (Klobuchar) ionosphere, Saastamoinen troposphere, the
systems asked for (``pos1-navsys``: 1 GPS, 8 Galileo, 32 BeiDou, 16 QZSS). RTKLIB reads neither Hatanaka nor
gzip without external programs, so the files are restored into a temporary folder first. Its solution file
(``out-solformat=xyz``, ``out-timeform=tow``) gives GPS week, time of week, ECEF X, Y, Z, quality and
number of satellites per epoch; epochs it has no solution for are absent.

Known differences, measured on the real stations (docs/positioning): at NYA1 its BeiDou residuals of
the BDS-2 IGSO satellites carry biases of about 2 m (C06 +1.9, C13 -2.2, C16 -1.6 m mean) that ours do not,
so its BeiDou and GPS+BeiDou solutions there are worse than ours (at ESBC the two agree to 3 cm); and
without GPS Klobuchar coefficients in the navigation file (a Galileo-only file) RTKLIB falls back to a
built-in default Klobuchar set where ours applies no ionosphere correction.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.timescale import gps_ns_from_week_tow, seconds_to_ns

__all__ = ["RtklibSolution", "run_rnx2rtkp", "NAVSYS_BITS"]

NAVSYS_BITS = {"G": 1, "S": 2, "R": 4, "E": 8, "J": 16, "C": 32, "I": 64}


@dataclass(frozen=True)
class RtklibSolution:
    """``gps_ns`` (epochs,), ``position_m`` (epochs, 3) ECEF, ``n_sats`` (epochs,), the command run."""

    gps_ns: np.ndarray
    position_m: np.ndarray
    n_sats: np.ndarray
    command: list[str]


def run_rnx2rtkp(obs_path, nav_paths, systems, *, elevation_mask_deg: float = 10.0, program: str = "rnx2rtkp",
                 timeout_s: float = 300.0) -> RtklibSolution:
    """RTKLIB's single-point solution of ``obs_path`` with ``nav_paths`` for the system letters ``systems``.

    Raises FileNotFoundError when the program is not installed (``apt-get install rtklib``) and
    RuntimeError with its message when it fails or writes no solution.
    """
    exe = shutil.which(program)
    if exe is None:
        raise FileNotFoundError(f"{program} not found: install Debian's rtklib package (apt-get install rtklib)")
    with tempfile.TemporaryDirectory(prefix="rtklib-") as tmp:
        work = Path(tmp)
        obs = work / "rover.obs"
        obs.write_bytes(rinex_bytes(obs_path))
        navs = []
        for k, p in enumerate(nav_paths):
            navs.append(work / f"nav{k}.nav")
            navs[-1].write_bytes(rinex_bytes(p))
        conf = work / "spp.conf"
        navsys = sum(NAVSYS_BITS[s] for s in systems)
        conf.write_text("\n".join([
            "pos1-posmode       =single", "pos1-frequency     =l1", f"pos1-elmask        ={elevation_mask_deg:g}",
            "pos1-ionoopt       =brdc", "pos1-tropopt       =saas", "pos1-sateph        =brdc",
            f"pos1-navsys        ={navsys}", "out-solformat      =xyz", "out-timeform       =tow", ""]))
        out = work / "solution.pos"
        command = [exe, "-k", str(conf), "-o", str(out), str(obs), *map(str, navs)]
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s)
        if done.returncode != 0 or not out.is_file():
            raise RuntimeError(f"rnx2rtkp failed ({done.returncode}): {done.stderr[-500:]}")
        rows = [line.split() for line in out.read_text().splitlines() if line and not line.startswith("%")]
    if not rows:
        raise RuntimeError("rnx2rtkp wrote no solution")
    table = np.array([[float(v) for v in r[:7]] for r in rows])
    week = table[:, 0].astype(np.int64)
    gps_ns = gps_ns_from_week_tow(week, seconds_to_ns(table[:, 1]))
    return RtklibSolution(gps_ns=np.asarray(gps_ns, dtype=np.int64), position_m=table[:, 2:5],
                          n_sats=table[:, 6].astype(np.int64), command=command)
