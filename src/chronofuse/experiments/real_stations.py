"""Real IGS stations shipped with the tests: their files, receivers and published coordinates.

A folder (``tests/data/rinex/igs``) holds each station's 24 h RINEX 3 observation file, the broadcast
navigation files of the same day, and ``stations.toml`` naming them with the station's reference coordinate:
a site of a SINEX solution shipped beside them (``sinex``/``site``) or an ECEF point with its source
(``ecef_m``). :func:`load_stations` reads that catalogue; :meth:`RealStation.observations` and
:meth:`RealStation.navigation` read the files (cached per process, they are read by many tests).

The reference is the marker; ``reference_arp_m`` adds the header's antenna offset (``ANTENNA: DELTA
H/E/N``, the same as the SINEX eccentricity), the point a code solution estimates to within the antenna's
phase-centre offset (centimetres).
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from chronofuse.validation import InputDataError

__all__ = ["RealStation", "load_stations"]


@dataclass(frozen=True)
class RealStation:
    """One station of the catalogue (module docstring)."""

    name: str
    make: str
    date: str
    obs_path: Path
    nav_paths: tuple[Path, ...]
    reference_m: np.ndarray
    reference_source: str

    def observations(self, observables=("C",)):
        """The observation file read by :func:`chronofuse.io.rinex_obs.read_observations` (cached)."""
        return _observations(self.obs_path, tuple(observables) if observables is not None else None)

    def navigation(self):
        """The navigation files read and merged (cached)."""
        return _navigation(self.nav_paths)

    @property
    def receiver(self) -> str:
        return self.observations().header.receiver

    @property
    def systems(self) -> list[str]:
        """Systems with both observations and ephemerides (letters, G E C J order)."""
        obs = set(self.observations().systems)
        return [s for s in self.navigation().systems if s in obs]

    @property
    def reference_arp_m(self) -> np.ndarray:
        """The marker plus the header's antenna offset (height, east, north), ECEF (3,)."""
        h, e, n = self.observations().header.antenna_delta_hen_m
        lat, lon, alt = pymap3d.ecef2geodetic(*self.reference_m)
        return np.array(pymap3d.enu2ecef(e, n, h, lat, lon, alt))


@functools.lru_cache(maxsize=8)
def _observations(path: Path, observables):
    from chronofuse.io.rinex_obs import read_observations

    return read_observations(path, observables=observables)


@functools.lru_cache(maxsize=8)
def _navigation(paths: tuple[Path, ...]):
    from chronofuse.io.rinex_nav import merge_navigation, read_navigation

    return merge_navigation([read_navigation(p) for p in paths])


def load_stations(folder) -> dict[str, RealStation]:
    """The stations of ``folder``/stations.toml (module docstring), by name. Raises
    :class:`InputDataError` naming the catalogue when a file it names is missing."""
    from chronofuse.io.sinex import read_sinex_stations

    folder = Path(folder)
    catalogue = folder / "stations.toml"
    if not catalogue.is_file():
        raise InputDataError("no stations.toml in the folder", str(folder))
    spec = tomllib.loads(catalogue.read_text())
    out = {}
    for name, entry in spec.items():
        files = [folder / entry["obs"], *(folder / p for p in entry["nav"])]
        missing = [str(p) for p in files if not p.is_file()]
        if missing:
            raise InputDataError(f"station {name}: missing {', '.join(missing)}", str(catalogue))
        ref = entry["reference"]
        if "sinex" in ref:
            site = read_sinex_stations(folder / ref["sinex"])[ref["site"]]
            position, source = site.position_m, f"{ref['sinex']} site {ref['site']} at {site.epoch}"
        else:
            position, source = np.asarray(ref["ecef_m"], dtype=np.float64), ref.get("frame", "")
        out[name] = RealStation(name=name, make=entry["make"], date=entry["date"], obs_path=files[0],
                                nav_paths=tuple(files[1:]), reference_m=position, reference_source=source)
    return out
