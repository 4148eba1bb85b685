"""Observables: L1 pseudoranges of a static receiver at a known position -> per-satellite receiver clock biases.

For a receiver at ``r_rx`` every satellite ``n`` gives its own estimate of the receiver clock bias::

    b_n(k) = (rho_n - |r_sat,n - r_rx| + c dt_sat,n - I_n - T_n) / c

with the broadcast orbit and clock of :mod:`chronofuse.gnss.ephemeris` (emission time from the pseudorange,
Sagnac included), the Klobuchar ionosphere ``I_n`` and the Saastamoinen troposphere ``T_n`` of
:mod:`chronofuse.gnss.atmosphere`, elevation from :mod:`chronofuse.gnss.geodesy`.
:class:`ChannelClockBiases` holds them on a regular epoch grid; ``chronofuse.io.rinex.channel_clock_biases``
builds one from RINEX files, :func:`channel_clock_biases_from_arrays` from arrays (e.g. a simulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.atmosphere import klobuchar_delay_s, saastamoinen_delay_m
from chronofuse.gnss.ephemeris import GpsNavigation, geometry_from_pseudorange, select_ephemeris
from chronofuse.gnss.geodesy import elevation_azimuth
from chronofuse.timescale import NS_PER_S, week_tow
from chronofuse.validation import check_array, check_scalar


@dataclass(frozen=True)
class ChannelClockBiases:
    """Per-satellite receiver clock biases on a regular epoch grid.

    Attributes
    ----------
    t_s : ndarray (epochs,)
        Seconds since the first epoch.
    gps_epoch_ns : ndarray of int64 (epochs,)
        GPS time of each grid epoch, ns since 1980-01-06.
    satellites : list of str (sats,)
    bias_s : ndarray (epochs, sats)
        ``b_n(k)`` (s), NaN where the satellite is not observed (or below the mask, or without ephemeris).
    interval_s : float
    n_skipped_epochs : int
        Grid epochs with no observation at all (missing from the file or unreadable there).
    n_unreadable_epochs : int
        Epoch records in the file that the RINEX reader could not read.
    elevation_rad : ndarray (epochs, sats) or None
    """

    t_s: np.ndarray
    gps_epoch_ns: np.ndarray
    satellites: list[str]
    bias_s: np.ndarray
    interval_s: float
    n_skipped_epochs: int
    n_unreadable_epochs: int = 0
    elevation_rad: np.ndarray | None = None


def corrected_ranges(eph, gps_ns, pseudorange_m, receiver_m, alpha, beta, elevation_mask_rad, *, geometry=None):
    """``(rho - |r_sat - r_rx| + c dt_sat - I - T)`` (m), shape (epochs, sats), NaN below the mask or
    without ephemeris; with the elevation (rad). ``alpha``/``beta`` None: no ionosphere correction.
    ``geometry``: the :func:`geometry_from_pseudorange` of these arguments when the caller has it already."""
    geo = geometry_from_pseudorange(eph, gps_ns, pseudorange_m, receiver_m) if geometry is None else geometry
    el, az = elevation_azimuth(receiver_m, geo.satellite_m)
    iono_m = 0.0
    if alpha is not None and beta is not None:
        tow_s = week_tow(gps_ns)[1][:, None] / NS_PER_S
        iono_m = SPEED_OF_LIGHT_M_PER_S * klobuchar_delay_s(alpha, beta, receiver_m, el, az, tow_s)
    tropo_m = saastamoinen_delay_m(receiver_m, el)
    out = pseudorange_m - geo.range_m + SPEED_OF_LIGHT_M_PER_S * geo.clock_s - iono_m - tropo_m
    out = np.where(eph.valid & (el >= elevation_mask_rad), out, np.nan)
    return out, el


def channel_biases(
    nav: GpsNavigation, satellites, gps_ns, pseudorange_m, position_ecef_m, *, elevation_mask_deg: float = 15.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(b_n(k) (s), elevation (rad))``, each (epochs, sats), of the pseudoranges ``pseudorange_m``
    (epochs, sats) of ``satellites`` received at ``gps_ns`` (int64 (epochs,)) by a receiver at
    ``position_ecef_m`` (3,); NaN below ``elevation_mask_deg`` or without a healthy ephemeris in ``nav``."""
    ranges_m, elevation = corrected_ranges(
        select_ephemeris(nav, satellites, gps_ns), gps_ns, pseudorange_m, position_ecef_m,
        nav.klobuchar_alpha, nav.klobuchar_beta, math.radians(elevation_mask_deg),
    )  # fmt: skip
    return ranges_m / SPEED_OF_LIGHT_M_PER_S, elevation


def channel_clock_biases_from_arrays(
    bias_s, interval_s: float, satellites=None, *, gps_epoch_ns=None, n_skipped_epochs: int | None = None
) -> ChannelClockBiases:
    """Wrap per-channel biases (s), shape (epochs, sats), NaN = not observed, e.g. from a simulation."""
    b = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    sats = [f"G{j + 1:02d}" for j in range(b.shape[1])] if satellites is None else [str(s) for s in satellites]
    if len(sats) != b.shape[1]:
        raise ValueError(f"satellites has {len(sats)} names, bias_s has {b.shape[1]} columns")
    epochs = b.shape[0]
    step_ns = int(round(interval_s * NS_PER_S))
    gps = np.arange(epochs, dtype=np.int64) * step_ns if gps_epoch_ns is None else np.asarray(gps_epoch_ns, np.int64)
    if gps.shape != (epochs,):
        raise ValueError(f"gps_epoch_ns has shape {gps.shape}, must be ({epochs},)")
    missing = int((~np.isfinite(b).any(axis=1)).sum()) if n_skipped_epochs is None else int(n_skipped_epochs)
    return ChannelClockBiases(
        t_s=np.arange(epochs) * float(interval_s),
        gps_epoch_ns=gps,
        satellites=sats,
        bias_s=b,
        interval_s=float(interval_s),
        n_skipped_epochs=missing,
    )


__all__ = [
    "ChannelClockBiases",
    "channel_biases",
    "channel_clock_biases_from_arrays",
    "corrected_ranges",
]
