"""Single-point positioning on the real stations, ours beside RTKLIB's, with epoch-by-epoch differences.

For each station of :mod:`chronofuse.experiments.real_stations` and each system combination its files
support: our fixes (:func:`chronofuse.gnss.point_positioning.point_positions`) and RTKLIB's
(:func:`chronofuse.experiments.rtklib.run_rnx2rtkp`) against the station's published coordinate (antenna
reference point), and the horizontal distance between the two solutions at the epochs both have.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from chronofuse.experiments.real_stations import RealStation
from chronofuse.gnss.point_positioning import SppOptions, enu_errors_m, point_positions, position_statistics

__all__ = ["COMBINATIONS", "REFERENCE_HEIGHT_RANGE_M", "REFERENCE_WARNING_DISTANCE_M", "station_comparison",
           "combinations_for", "check_reference_position", "position_from_files", "write_positions_csv"]

#: The combinations compared, by name: GPS alone, GPS+BDS, Galileo alone, BDS alone, all three.
COMBINATIONS = {"gps": ("G",), "gps+bds": ("G", "C"), "gal": ("E",), "bds": ("C",), "gps+gal+bds": ("G", "E", "C")}


def combinations_for(station: RealStation) -> list[str]:
    """The combinations of :data:`COMBINATIONS` whose systems all have observations and ephemerides."""
    have = set(station.systems)
    return [name for name, letters in COMBINATIONS.items() if set(letters) <= have]


def _epoch_differences(ours_ns, ours_m, theirs_ns, theirs_m, reference_m) -> dict:
    common, i, j = np.intersect1d(ours_ns, theirs_ns, return_indices=True)
    ok = np.isfinite(ours_m[i]).all(-1)
    d = enu_errors_m(ours_m[i][ok], reference_m) - enu_errors_m(theirs_m[j][ok], reference_m)
    horizontal = np.hypot(d[:, 0], d[:, 1])
    pct = lambda v, q: float(np.percentile(v, q)) if v.size else float("nan")  # noqa: E731
    return {"common_epochs": int(ok.sum()), "horizontal_median_m": pct(horizontal, 50),
            "horizontal95_m": pct(horizontal, 95), "vertical_median_m": pct(np.abs(d[:, 2]), 50),
            "vertical95_m": pct(np.abs(d[:, 2]), 95)}


def station_comparison(station: RealStation, combinations=None, *, options: SppOptions | None = None,
                       rtklib: bool = True, progress: Callable[[str], None] | None = None) -> dict:
    """Statistics of ours and RTKLIB's per combination (module docstring), as a JSON-ready dict."""
    opt = options or SppOptions()
    obs, nav = station.observations(), station.navigation()
    reference = station.reference_arp_m
    out = {"station": station.name, "make": station.make, "receiver": station.receiver, "date": station.date,
           "reference_source": station.reference_source, "epochs": int(obs.gps_ns.size), "combinations": {}}
    for name in combinations or combinations_for(station):
        letters = COMBINATIONS[name]
        if progress is not None:
            progress(f"{station.name} {name}")
        ours = point_positions(obs, nav, letters, opt)
        row = {"systems": list(letters), "codes": ours.codes, "ours": position_statistics(ours.position_m, reference),
               "mean_satellites": float(np.mean(ours.n_used[ours.n_used > 0])) if (ours.n_used > 0).any() else 0.0,
               "excluded": int(ours.n_excluded.sum())}
        if rtklib:
            from chronofuse.experiments.rtklib import run_rnx2rtkp

            theirs = run_rnx2rtkp(station.obs_path, station.nav_paths, letters,
                                  elevation_mask_deg=opt.elevation_mask_deg)
            rtk = position_statistics(theirs.position_m, reference)
            rtk["availability"] = theirs.gps_ns.size / obs.gps_ns.size
            row["rtklib"] = rtk
            row["ratio_horizontal95"] = row["ours"]["horizontal95_m"] / rtk["horizontal95_m"]
            row["differences"] = _epoch_differences(ours.gps_ns, ours.position_m, theirs.gps_ns, theirs.position_m,
                                                    reference)
        out["combinations"][name] = row
    return out


#: Where a reference position may lie: ellipsoidal height (WGS 84) between these (m). The lowest land is
#: about -430 m and geoid heights stay within about 110 m, so -10 km leaves room for a mine shaft; +100 km is
#: the edge of space (a static reference antenna is on or near the ground). Outside: not a position on Earth
#: (0,0,0, a unit slip, a swapped axis).
REFERENCE_HEIGHT_RANGE_M = (-10_000.0, 100_000.0)
#: A reference further than this from the mean of the fixes is analysed, with a warning (a reference of
#: another station, or a wrong datum).
REFERENCE_WARNING_DISTANCE_M = 1000.0


def check_reference_position(reference_m) -> np.ndarray:
    """``reference_m`` as a finite ECEF point (3,) within :data:`REFERENCE_HEIGHT_RANGE_M` of the WGS 84
    ellipsoid; raises :class:`~chronofuse.validation.InputError` naming ``{reference_m}`` otherwise."""
    import pymap3d

    from chronofuse.validation import InputError

    ref = np.asarray(reference_m, dtype=np.float64)
    if ref.shape != (3,) or not np.isfinite(ref).all():
        raise InputError(f"{{reference_m}} == {[float(v) for v in np.ravel(ref)]}, must be three finite ECEF coordinates (m)",
                         fields=("reference_m",))
    h = float(pymap3d.ecef2geodetic(*ref)[2])
    lo, hi = REFERENCE_HEIGHT_RANGE_M
    if not lo <= h <= hi:
        raise InputError(f"{{reference_m}} == {[float(v) for v in ref]} is {h / 1000:,.1f} km from the WGS 84 "
                         f"ellipsoid, must be between {lo / 1000:g} and {hi / 1000:g} km (an antenna on Earth)",
                         fields=("reference_m",))
    return ref


def _check_window(start_s, end_s) -> None:
    from chronofuse.validation import InputError, check_scalar

    for value, name in ((start_s, "start_s"), (end_s, "end_s")):
        if value is not None:
            check_scalar(value, name, min_val=0.0)  # seconds after the file's first epoch
    if start_s is not None and end_s is not None and end_s < start_s:
        raise InputError(f"{{end_s}} == {end_s:g} is before {{start_s}} == {start_s:g}", fields=("start_s", "end_s"))


def _no_fix_reason(fixes, options: SppOptions) -> str:
    """Why no epoch gave a fix: too few usable satellites, or the geometry."""
    usable = np.isfinite(fixes.corrected_m).sum(-1) if fixes.corrected_m is not None else np.zeros(1, dtype=int)
    from chronofuse.gnss.systems import system_names

    needed = 3 + len(fixes.systems)
    most = int(usable.max())
    if most < needed:
        return (f"no epoch gives a fix: at most {most} usable satellite{'s' if most != 1 else ''} at an epoch (above "
                f"the elevation mask, with an ephemeris), and {system_names(fixes.systems)} needs {needed}")
    return f"no epoch gives a fix: GDOP above {options.max_gdop:g} (or the solution failed) at every epoch"


#: Fewer fixes than this share of the observation epochs is analysed, with a warning naming the span fixed (a
#: navigation file covering part of the day gives fixes only there, and its statistics describe that part).
FIX_SHARE_WARNING = 0.5


def _warn_unused_systems(fixes, ok, systems, nav_source: str) -> None:
    """Warn when a system asked for gave no satellite to any fix (its records serve none of the epochs: another
    day's file, say, so a comparison with and without it compares the same fixes), and when fewer than
    :data:`FIX_SHARE_WARNING` of the epochs have a fix."""
    import warnings

    from chronofuse.gnss.systems import system_names
    from chronofuse.timescale import gps_ns_to_utc
    from chronofuse.validation import InputWarning

    used = np.isfinite(fixes.residual_m[ok])
    for letter in systems:
        cols = [k for k, name in enumerate(fixes.satellites) if name[:1] == letter]
        if not used[:, cols].any():
            warnings.warn(InputWarning(f"{system_names((letter,))} gave no satellite to any fix: none of its broadcast "
                                       f"records in the navigation ({nav_source}) serves the observation epochs; the "
                                       "fixes are the other systems' alone", fields=("nav",)), stacklevel=3)
    share = float(ok.mean()) if ok.size else 0.0
    if ok.any() and share < FIX_SHARE_WARNING:
        fixed = fixes.gps_ns[ok]
        warnings.warn(InputWarning(f"{int(ok.sum())} of {ok.size} epochs have a fix ({share:.0%}), from "
                                   f"{str(gps_ns_to_utc(fixed[0]))[:19]} to {str(gps_ns_to_utc(fixed[-1]))[:19]} UTC: the "
                                   f"statistics describe that span (does the navigation, {nav_source}, cover the "
                                   "observations?)", fields=("nav",)), stacklevel=3)


def position_from_files(obs_path, nav_paths, systems, *, options: SppOptions | None = None, start_s=None,
                        end_s=None, reference_m=None) -> tuple:
    """Read an observation file (RINEX 2 or 3, plain / gz / Hatanaka) and navigation files, and solve.

    ``systems``: letters; ``start_s``/``end_s``: seconds from the file's first epoch (>= 0); ``reference_m``
    (3,) ECEF (:func:`check_reference_position`): statistics against it. Returns ``(PointPositions, summary
    dict)``. Raises :class:`~chronofuse.validation.InputError` when no epoch gives a fix (naming why), and
    warns when the reference is more than :data:`REFERENCE_WARNING_DISTANCE_M` from the mean fix.
    """
    import warnings

    from chronofuse.io.rinex_nav import merge_navigation, read_navigation
    from chronofuse.io.rinex_obs import read_any_observations
    from chronofuse.timescale import NS_PER_S
    from chronofuse.validation import InputDataError, InputError, InputWarning

    opt = options or SppOptions()
    _check_window(start_s, end_s)
    if reference_m is not None:
        reference_m = check_reference_position(reference_m)
    obs = read_any_observations(obs_path, systems=systems)
    first = int(obs.gps_ns[0])
    if start_s is not None or end_s is not None:
        lo = first + int(round((start_s or 0.0) * NS_PER_S))
        hi = first + int(round(end_s * NS_PER_S)) if end_s is not None else int(obs.gps_ns[-1])
        rows = (obs.gps_ns >= lo) & (obs.gps_ns <= hi)
        if not rows.any():
            span = (obs.gps_ns[-1] - obs.gps_ns[0]) / NS_PER_S
            window = (f"{{start_s}} == {start_s or 0.0:g} s to "
                      + (f"{{end_s}} == {end_s:g} s" if end_s is not None else "the file's end"))
            raise InputError(f"no epoch in the window {window} (seconds after the file's first epoch; its epochs span "
                             f"{span:g} s)", str(obs_path), fields=("start_s", "end_s"))
        obs = obs.select(rows)
    nav = merge_navigation([read_navigation(p) for p in nav_paths])
    fixes = point_positions(obs, nav, systems, opt)
    if not np.isfinite(fixes.position_m[:, 0]).any():
        raise InputDataError(f"{_no_fix_reason(fixes, opt)} (navigation: {nav.source})", str(obs_path))
    summary = {"obs": str(obs_path), "nav": [str(p) for p in nav_paths], "systems": list(systems),
               "codes": fixes.codes, "receiver": obs.header.receiver, "marker": obs.header.marker,
               "epochs": int(obs.gps_ns.size), "fixes": int(np.isfinite(fixes.position_m[:, 0]).sum()),
               "excluded_measurements": int(fixes.n_excluded.sum()),
               "mean_satellites": float(fixes.n_used[fixes.n_used > 0].mean()) if (fixes.n_used > 0).any() else 0.0,
               "unreadable_epochs": int(obs.n_unreadable_epochs)}
    ok = np.isfinite(fixes.position_m[:, 0])
    _warn_unused_systems(fixes, ok, systems, nav.source)
    if ok.any():
        summary["mean_position_m"] = [float(v) for v in fixes.position_m[ok].mean(0)]
    if reference_m is not None:
        distance = float(np.linalg.norm(np.asarray(summary["mean_position_m"]) - reference_m))
        if distance > REFERENCE_WARNING_DISTANCE_M:
            warnings.warn(InputWarning(f"{{reference_m}} is {distance / 1000:,.1f} km from the mean fix: the statistics "
                                       "measure that distance (another station's coordinate, or a wrong datum?)",
                                       fields=("reference_m",)), stacklevel=2)
        summary["reference_position_m"] = [float(v) for v in reference_m]
        summary["statistics"] = position_statistics(fixes.position_m, reference_m)
    return fixes, summary


def write_positions_csv(fixes, path, reference_m=None) -> int:
    """One row per epoch: GPS week and time of week, ECEF (m), latitude/longitude (deg), height (m), receiver
    clock (``clock_m`` and ``clock_s``), inter-system biases (``isb_<sys>_m``), satellites used and excluded,
    DOPs, and east/north/up errors (m) when a reference is given. Returns the number of rows."""
    import pandas as pd
    import pymap3d

    from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
    from chronofuse.timescale import NS_PER_S, week_tow

    week, tow_ns = week_tow(fixes.gps_ns)
    p = fixes.position_m
    lat, lon, h = pymap3d.ecef2geodetic(p[:, 0], p[:, 1], p[:, 2])
    table = {"gps_week": week, "tow_s": tow_ns / NS_PER_S, "x_m": p[:, 0], "y_m": p[:, 1], "z_m": p[:, 2],
             "lat_deg": lat, "lon_deg": lon, "height_m": h, "clock_m": fixes.clock_m,
             "clock_s": fixes.clock_m / SPEED_OF_LIGHT_M_PER_S}
    for k, letter in enumerate(fixes.systems[1:]):
        table[f"isb_{letter}_m"] = fixes.isb_m[:, k]
    table.update({"n_used": fixes.n_used, "n_excluded": fixes.n_excluded, "gdop": fixes.gdop, "pdop": fixes.pdop,
                  "hdop": fixes.hdop, "vdop": fixes.vdop})
    if reference_m is not None:
        enu = enu_errors_m(p, reference_m)
        table.update({"east_m": enu[:, 0], "north_m": enu[:, 1], "up_m": enu[:, 2]})
    frame = pd.DataFrame(table)
    for name in frame.columns:  # 0.1 mm, and 1e-9 deg (0.1 mm) for the angles
        if frame[name].dtype.kind == "f":
            frame[name] = frame[name].round(12 if name == "clock_s" else 9 if name in ("lat_deg", "lon_deg") else 4)
    frame.to_csv(path, index=False)
    return len(frame)
