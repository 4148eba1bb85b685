"""A static station's channels: every code of every system, as per-satellite receiver clock biases on the
epoch grid.

From a RINEX observation file (2 or 3, plain, gzip or Hatanaka: :func:`chronofuse.io.rinex_obs.read_any_observations`,
where a blank or 0.000 observation is missing) and broadcast navigation (:func:`chronofuse.io.rinex_nav.read_navigation`,
GPS, Galileo, BeiDou, QZSS) for an antenna at a known position, each channel ``(satellite, code)`` gives
its own estimate of the receiver clock bias (:func:`chronofuse.gnss.observables.channel_biases`):
``b_n(k) = (rho_n - |r_sat,n - r_rx| + c dt_sat,n - I_n - T_n) / c``. The single-frequency model (the L1
group delay, the Klobuchar delay at L1) is applied to every code; what it misses on another band (the
inter-frequency bias, the ionosphere's frequency scaling) is slow and constant enough for the second
difference to remove.

Which codes (:func:`station_codes`): every pseudorange observable of a system with ephemerides whose channels
hold data in at least :data:`MIN_CODE_SHARE` of that system's observed satellite-epochs (a code a receiver
tracks on a few satellites only has too few channels for the others' clock), or those asked for
(``codes``, e.g. ``("G C1C", "G C2W", "E C1X")``). GLONASS and SBAS are not used (no ephemeris model here).

Epochs are placed on the grid of the header's ``INTERVAL`` (else the smallest spacing) within 1 % of an
interval (receivers that steer their clock in milliseconds tag epochs a few ms off it); a grid epoch with no
observation is a NaN column, counted in ``n_skipped_epochs``. The geometry is computed at the grid epoch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from chronofuse.gnss.observables import channel_biases
from chronofuse.io.grid import grid_slots
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputError, invalid

__all__ = ["StationChannels", "station_channels", "station_codes", "MIN_CODE_SHARE", "KEPLER_SYSTEMS"]

#: Systems whose broadcast ephemerides are modelled.
KEPLER_SYSTEMS = ("G", "E", "C", "J")

#: Least share of a system's observed satellite-epochs a code must hold to be used by default.
MIN_CODE_SHARE = 0.3

_GRID_TOLERANCE = 0.01


@dataclass(frozen=True)
class StationChannels:
    """Channels of a static station (module docstring).

    ``t_ns`` (epochs,) grid epochs, GPS ns; ``interval_ns``; ``channels`` list of ``(satellite, code)`` (code
    as ``"G C1C"``); ``bias_s`` and ``elevation_deg`` (channels, epochs), NaN where not observed, below the
    mask or without ephemeris; ``codes`` in channel order; ``position_m`` (3,) ECEF; ``source``;
    ``n_skipped_epochs``; ``observations`` and ``navigation`` (what was read, for the fixes).
    """

    t_ns: np.ndarray
    interval_ns: int
    channels: list
    bias_s: np.ndarray
    elevation_deg: np.ndarray
    codes: list
    position_m: np.ndarray
    source: str
    n_skipped_epochs: int
    slots: np.ndarray = field(repr=False)
    observations: object = field(repr=False, default=None)
    navigation: object = field(repr=False, default=None)

    @property
    def n_epochs(self) -> int:
        return int(self.t_ns.size)

    @property
    def interval_s(self) -> float:
        return self.interval_ns / NS_PER_S

    def frame(self) -> dict:
        """The pipeline's columns: ``t_ns`` (epochs,), ``channel_bias_s`` and ``elevation_deg`` (channels, epochs)."""
        return {"t_ns": self.t_ns, "channel_bias_s": self.bias_s, "elevation_deg": self.elevation_deg}

    def with_bias(self, bias_s: np.ndarray) -> StationChannels:
        """The same channels with other biases (an injected fault)."""
        import dataclasses

        return dataclasses.replace(self, bias_s=np.asarray(bias_s, dtype=np.float64))

    def epochs(self, start: int, stop: int) -> StationChannels:
        """Grid epochs ``start:stop`` only, without what was read (``observations``/``navigation`` None: no
        single-point fix of a stretch)."""
        import dataclasses

        sl = slice(int(start), int(stop))
        return dataclasses.replace(self, t_ns=self.t_ns[sl], bias_s=self.bias_s[:, sl],
                                   elevation_deg=self.elevation_deg[:, sl], slots=np.zeros(0, dtype=np.int64),
                                   observations=None, navigation=None,
                                   n_skipped_epochs=int((~np.isfinite(self.bias_s[:, sl]).any(axis=0)).sum()))

    def rows_of(self, satellite: str) -> np.ndarray:
        """The channel rows of ``satellite``."""
        return np.array([i for i, (s, _) in enumerate(self.channels) if s == satellite], dtype=np.intp)


def station_codes(obs, nav, codes=None, systems=None) -> list[str]:
    """The codes used (module docstring): ``"<system> <observable>"`` labels, in G E C J order."""
    have = set(nav.systems) & set(KEPLER_SYSTEMS)
    if systems is not None:
        have &= set(systems)
    if codes is not None:
        out = []
        for label in codes:
            parts = str(label).split()
            if len(parts) != 2 or len(parts[1]) != 3 or parts[1][0] != "C":
                raise InputError(f"{{codes}}: {label!r} is not a system letter and a RINEX 3 pseudorange "
                                 "observable, e.g. 'G C1C'", obs.source, fields=("codes",))
            letter, name = parts
            if letter not in have:
                raise InputError(f"{{codes}}: {label!r} has no {letter} ephemeris in the navigation data (it has "
                                 f"{', '.join(nav.systems) or 'none'})", obs.source, fields=("codes",))
            mask = obs.system_mask(letter)
            if name not in obs.values or not np.isfinite(obs.values[name][:, mask]).any():
                raise InputError(f"{{codes}}: no pseudorange {label!r} in the observations", obs.source,
                                 fields=("codes",))
            out.append(f"{letter} {name}")
        return out
    out = []
    for letter in KEPLER_SYSTEMS:
        if letter not in have:
            continue
        mask = obs.system_mask(letter)
        if not mask.any():
            continue
        seen = np.zeros((obs.gps_ns.size, int(mask.sum())), dtype=bool)
        for name, values in obs.values.items():
            if name.startswith("C"):
                seen |= np.isfinite(values[:, mask])
        total = int(seen.sum())
        for name in sorted(v for v in obs.values if v.startswith("C")):
            held = int(np.isfinite(obs.values[name][:, mask]).sum())
            if total and held >= MIN_CODE_SHARE * total:
                out.append(f"{letter} {name}")
    if not out:
        raise InputError("no pseudorange code of a system with ephemerides (GPS, Galileo, BeiDou, QZSS) in the "
                             "observations", obs.source)
    return out


def _grid(obs) -> tuple[np.ndarray, int, int]:
    gps = obs.gps_ns
    interval = getattr(obs.header, "interval_s", None)
    if interval:
        step_ns = int(round(interval * NS_PER_S))
    elif gps.size > 1:
        step_ns = int(np.diff(gps).min())
    else:
        raise InputError("one epoch and no INTERVAL in the header: the sampling interval is unknown", obs.source)
    slots, bad = grid_slots((gps - gps[0]).astype(np.float64), float(step_ns), _GRID_TOLERANCE)
    if bad >= 0:
        raise InputError(f"epoch {bad + 1} is not on the {step_ns / NS_PER_S:g} s grid (or not increasing)",
                             obs.source)
    return slots, step_ns, int(slots[-1]) + 1


def station_channels(obs, nav, position_m, *, codes=None, systems=None, elevation_mask_deg: float = 10.0
                     ) -> StationChannels:
    """The channels of ``obs`` (a :class:`chronofuse.io.rinex_obs.GnssObservations`) with ``nav`` for an
    antenna at ``position_m`` (ECEF, m) (module docstring). Raises :class:`InputError` naming the file
    when no code can be used or the epochs are off their grid."""
    position = np.asarray(position_m, dtype=np.float64)
    if position.shape != (3,) or not np.isfinite(position).all():
        raise InputError(f"{{position_m}} has shape {position.shape}, must be (3,) finite ECEF metres",
                         fields=("position_m",))
    if not 0.0 <= elevation_mask_deg < 90.0 or not math.isfinite(elevation_mask_deg):
        raise invalid("elevation_mask_deg", elevation_mask_deg, "in [0, 90) degrees")
    labels = station_codes(obs, nav, codes, systems)
    slots, step_ns, epochs = _grid(obs)
    t_ns = obs.gps_ns[0] + np.arange(epochs, dtype=np.int64) * step_ns
    grid_ns = t_ns[slots]
    channels, biases, elevations = [], [], []
    for label in labels:
        letter, name = label.split()
        mask = obs.system_mask(letter)
        sats = [s for s, m in zip(obs.satellites, mask) if m]
        rho = obs.values[name][:, mask]
        keep = np.isfinite(rho).any(axis=0)
        if not keep.any():
            continue
        sats = [s for s, k in zip(sats, keep) if k]
        b, el = channel_biases(nav, sats, grid_ns, rho[:, keep], position, elevation_mask_deg=elevation_mask_deg)
        full_b = np.full((len(sats), epochs), np.nan)
        full_el = np.full((len(sats), epochs), np.nan)
        full_b[:, slots] = b.T
        full_el[:, slots] = np.degrees(np.where(np.isfinite(b), el, np.nan)).T
        for j, sat in enumerate(sats):
            if np.isfinite(full_b[j]).any():
                channels.append((sat, label))
                biases.append(full_b[j])
                elevations.append(full_el[j])
    if not channels:
        raise InputError("no channel above the elevation mask with an ephemeris (is the navigation file of "
                             "this day?)", obs.source)
    used = list(dict.fromkeys(c for _, c in channels))
    return StationChannels(t_ns=t_ns, interval_ns=step_ns, channels=channels, bias_s=np.array(biases),
                           elevation_deg=np.array(elevations), codes=used, position_m=position, source=obs.source,
                           n_skipped_epochs=epochs - int(np.unique(slots).size), slots=slots, observations=obs,
                           navigation=nav)
