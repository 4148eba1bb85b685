"""Helpers of the monitor tests: synthetic u-blox streams (serialized by pyubx2) and the real captures."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
from pyubx2 import GET, UBXMessage

WEEK = 2300  # 2024-02-04


def ubx_stream(clock_bias_s: np.ndarray, *, week: int = WEEK, start_tow_s: int = 100_000, leap_s: int = 18,
               gdop: float = 2.1, fix_type: int = 3, eoe: bool = False) -> bytes:
    """One epoch per second: NAV-TIMEGPS (week, leap), NAV-PVT (fix, UTC), NAV-DOP, NAV-CLOCK (``clkB`` =
    the given bias, in whole ns as the receiver sends it), and with ``eoe`` the NAV-EOE that ends it."""
    return b"".join(ubx_epochs(clock_bias_s, week=week, start_tow_s=start_tow_s, leap_s=leap_s, gdop=gdop,
                               fix_type=fix_type, eoe=eoe))


def ubx_epochs(clock_bias_s, *, week: int = WEEK, start_tow_s: int = 100_000, leap_s: int = 18, gdop: float = 2.1,
               fix_type: int = 3, eoe: bool = False) -> list[bytes]:
    """:func:`ubx_stream`, one bytes object per epoch."""
    epochs = []
    for k, bias in enumerate(clock_bias_s):
        out = []
        tow_s = start_tow_s + k
        itow = tow_s * 1000
        utc = np.datetime64("1980-01-06T00:00:00", "s") + np.timedelta64(week * 604800 + tow_s - leap_s, "s")
        y, mo, d = (int(v) for v in str(utc)[:10].split("-"))
        h, mi, s = (int(v) for v in str(utc)[11:19].split(":"))
        out.append(UBXMessage("NAV", "NAV-TIMEGPS", GET, iTOW=itow, fTOW=0, week=week, leapS=leap_s, towValid=1,
                              weekValid=1, leapSValid=1, tAcc=10).serialize())
        out.append(UBXMessage("NAV", "NAV-PVT", GET, iTOW=itow, year=y, month=mo, day=d, hour=h, min=mi, second=s,
                              validDate=1, validTime=1, fullyResolved=1, fixType=fix_type, gnssFixOk=1, numSV=9,
                              pDOP=1.5).serialize())
        out.append(UBXMessage("NAV", "NAV-DOP", GET, iTOW=itow, gDOP=gdop, pDOP=1.5, tDOP=1.0, vDOP=1.2, hDOP=0.9,
                              nDOP=0.6, eDOP=0.6).serialize())
        out.append(UBXMessage("NAV", "NAV-CLOCK", GET, iTOW=itow, clkB=int(round(bias * 1e9)), clkD=0, tAcc=10,
                              fAcc=100).serialize())
        if eoe:
            out.append(UBXMessage("NAV", "NAV-EOE", GET, iTOW=itow).serialize())
        epochs.append(b"".join(out))
    return epochs


def _io_conftest():
    spec = importlib.util.spec_from_file_location("_io_conftest", Path(__file__).resolve().parents[1] / "io" / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


receivers_dir = _io_conftest().receivers_dir
