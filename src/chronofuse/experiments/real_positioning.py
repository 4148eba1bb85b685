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

__all__ = ["COMBINATIONS", "station_comparison", "combinations_for"]

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
