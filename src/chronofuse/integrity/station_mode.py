"""Integrity of a static station from its RINEX observations: every code of every system, satellites named
alone, the receiver clock watched beside them, and the known position checked without the named satellites.

:func:`station_document` is what ``chronofuse detect OBS --nav NAV --position X,Y,Z`` does:

1. **Channels.** :func:`chronofuse.io.station_channels.station_channels` turns the observations (RINEX 2 or
   3, plain, gzip or Hatanaka; blank and 0.000 fields missing) and the broadcast navigation into per-channel
   clock biases for every code of GPS, Galileo, BeiDou and QZSS (or the ``codes`` asked for), above
   ``elevation_mask_deg``.
2. **Identification.** The first ``train_s`` seconds fit each code's noise
   (:mod:`chronofuse.integrity.station_noise`) and are not tested; then
   :class:`chronofuse.integrity.station_identify.StationIdentification` tests every channel at each epoch with
   ``test`` (``chi-square`` or ``glr``) and names faulty satellites by exclusion.
3. **Receiver clock.** The common clock of the first code (the receiver clock bias the channels share,
   named satellites left out) runs through detection mode
   (:func:`chronofuse.integrity.station_receiver_clock.receiver_clock_test`, its noise trained on the same
   ``train_s``): a fault that moves every satellite at once leaves the residuals untouched and is caught
   here, reported as a receiver-clock fault.
4. **Station-level false alarms.** The station's ``pfa`` per epoch is split by Boole's inequality: the
   receiver clock's test gets ``reserved * pfa``, the ``m`` channel tests of the epoch ``(1 - reserved) pfa /
   m`` each; so ``P(any alarm at an epoch) <= pfa`` under H0 whatever the dependence between the tests.
5. **Known position.** The data's own single-point fix (:func:`chronofuse.gnss.point_positioning.point_positions`)
   with every satellite named at an epoch left out of that epoch, at :data:`POSITION_CHECK_EPOCHS` epochs
   spread over the record and at every epoch with a satellite named; the record is ``unavailable`` when its
   median distance from ``position_m`` exceeds :data:`POSITION_TOLERANCE_M` (a wrong position, not a fault).

Per-epoch states: ``training``; ``alarm`` (a satellite named, an unidentified alarm, or the receiver clock in
alarm); ``unavailable`` (fewer than :data:`chronofuse.integrity.station_identify.MIN_TESTED_SATELLITES`
satellites tested outside the named ones); ``ok``. Times ``t_ns`` are GPS ns of the grid epochs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from chronofuse.integrity.availability import POSITION_TOLERANCE_M, availability, overall_state
from chronofuse.integrity.document import base_document
from chronofuse.integrity.station_identify import MIN_TESTED_SATELLITES, IdentificationSettings, StationIdentification
from chronofuse.validation import InputError, check_scalar

__all__ = ["station_document", "station_integrity", "read_station", "DEFAULT_RESERVED", "POSITION_CHECK_EPOCHS"]

#: Share of the station's P_fa given to the receiver clock's test by default.
DEFAULT_RESERVED = 0.1


def read_station(obs_path, nav_paths, position_m, *, codes=None, elevation_mask_deg: float = 10.0):
    """The :class:`chronofuse.io.station_channels.StationChannels` of an observation file and its navigation
    files (one path or several, merged)."""
    from chronofuse.io.rinex_nav import merge_navigation, read_navigation
    from chronofuse.io.rinex_obs import read_any_observations
    from chronofuse.io.station_channels import station_channels

    paths = [nav_paths] if isinstance(nav_paths, (str, Path)) else list(nav_paths)
    obs = read_any_observations(obs_path)
    nav = merge_navigation([read_navigation(p) for p in paths])
    return station_channels(obs, nav, position_m, codes=codes, elevation_mask_deg=elevation_mask_deg)


def _receiver_clock(out: dict, training: np.ndarray, settings: IdentificationSettings):
    from chronofuse.integrity.station_receiver_clock import receiver_clock_test

    return receiver_clock_test(out["receiver_clock_s"], training, window=settings.window,
                               alpha=settings.pfa * settings.reserved, test=settings.test,
                               confidence=settings.confidence)


#: Most epochs the known-position check solves (evenly spaced over the record, every epoch with a satellite
#: named among them): its verdict is a median over the day, which 360 fixes estimate to well under a metre.
POSITION_CHECK_EPOCHS = 360


def _masked_fix_offsets(channels, named: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Distance (m) of the single-point fix from ``position`` at the epochs checked (at most
    :data:`POSITION_CHECK_EPOCHS` evenly spaced, plus every epoch with a satellite named), the satellites named
    at an epoch left out of it; NaN elsewhere (not checked, or no fix)."""
    from chronofuse.gnss.point_positioning import point_positions

    obs = channels.observations
    slots = np.asarray(channels.slots)
    names_at = np.asarray(named, dtype=object)[slots]
    step = max(1, int(math.ceil(slots.size / POSITION_CHECK_EPOCHS)))
    rows = np.zeros(slots.size, dtype=bool)
    rows[::step] = True
    rows |= names_at.astype(bool)
    sel = np.flatnonzero(rows)
    picked = obs.select(sel)
    column = {sat: j for j, sat in enumerate(obs.satellites)}
    hit = np.zeros((sel.size, len(obs.satellites)), dtype=bool)
    for i, text in enumerate(names_at[sel]):
        for sat in filter(None, str(text).split(",")):
            if sat in column:
                hit[i, column[sat]] = True
    if hit.any():
        for v in picked.values.values():
            v[hit] = np.nan
    systems = tuple(dict.fromkeys(c.split()[0] for c in channels.codes))
    fix = point_positions(picked, channels.navigation, systems=systems)
    out = np.full(channels.n_epochs, np.nan)
    out[slots[sel]] = np.linalg.norm(np.asarray(fix.position_m) - position[None, :], axis=1)
    return out


def station_document(obs_path, nav_paths, position_m, **options) -> dict:
    """:func:`station_integrity`'s document alone."""
    return station_integrity(obs_path, nav_paths, position_m, **options)[0]


def station_integrity(obs_path, nav_paths, position_m, *, train_s: float = 7200.0, window: int = 20,
                      pfa: float = 1e-3, test: str = "chi-square", codes=None, elevation_mask_deg: float = 10.0,
                      reserved: float = DEFAULT_RESERVED, channels=None, noise=None, check_position: bool = True,
                      progress=None) -> tuple[dict, dict]:
    """Station integrity (module docstring): ``(document, columns)``, the columns the identification stage
    gives per epoch (step axis last). The document has the keys of every detect document,
    ``faulty`` (each satellite named: ``channel``, ``t_ns``, ``t``), ``channel_events``, ``receiver_clock``
    (``state``, ``pfa``, ``alarms`` with ``t_ns``), ``codes``, ``n_channels``, ``code_noise`` (per code),
    ``station_pfa`` (the method), ``test``. ``channels`` (a :class:`StationChannels`) skips the reading;
    ``noise`` (fitted models by code) skips the fit; ``check_position=False`` skips the known-position check.
    ``progress(message, fraction)`` (:mod:`chronofuse.progress`) hears the stages and the fraction done."""
    from chronofuse.integrity.inputs import parse_position
    from chronofuse.progress import silent, stages

    # shares measured on a day of a RINEX 3 station at 30 s (ESBC00DNK, 2880 epochs, 263 s on a loaded
    # machine): reading 8 %, the per-code noise fit 12 %, the epochs 78 %, the known-position check 2 %
    reading, fitting, testing, fixing = stages(progress or silent, (0.08 if channels is None else 0.0, 0.12, 0.78, 0.02))

    check_scalar(train_s, "train_s", min_val=0.0, include_min=False)
    position = parse_position(position_m)
    settings = IdentificationSettings(window=window, pfa=pfa, test=test, reserved=reserved)
    if channels is None:
        reading("reading the observations and the navigation")
    ch = channels if channels is not None else read_station(obs_path, nav_paths, position, codes=codes,
                                                            elevation_mask_deg=elevation_mask_deg)
    t_ns = ch.t_ns
    training = (t_ns - t_ns[0]) < int(round(train_s * 1e9))
    n_train = int(training.sum())
    if n_train >= t_ns.size:
        raise InputError(f"the training stretch ({{train_s}} {train_s:g} s) covers the whole record "
                         f"({t_ns.size} epochs of {ch.interval_s:g} s)", ch.source, fields=("train_s",))
    frame = dict(ch.frame(), training=training)
    fitting(f"fitting the noise of {len(dict.fromkeys(c for _, c in ch.channels))} codes")
    stage = StationIdentification(ch.channels, settings, noise).fit(frame)
    reasons = [f"{code}: {why}" for code, why in stage.fit_problems_.items()]
    if not stage.noise_:
        raise InputError("no code could be trained: " + "; ".join(reasons), ch.source)
    out = stage.run(frame, progress=testing)
    clock = _receiver_clock(out, training, settings) if reserved > 0 else None
    states = np.asarray(out["identification_state"], dtype=object).copy()
    if clock is not None:
        states[clock.alarm] = "alarm"
    per_epoch = np.full(t_ns.size, "", dtype=object)
    per_epoch[training] = "training"
    per_epoch[states == "unavailable"] = f"fewer than {MIN_TESTED_SATELLITES} satellites tested outside the named ones"
    fixing("checking the position given against the data's own fix")
    offsets = (_masked_fix_offsets(ch, np.asarray(out["named"], dtype=object), position) if check_position
               else np.full(t_ns.size, np.nan))
    finite = offsets[np.isfinite(offsets)]
    state_reasons: list[str] = []
    if finite.size and float(np.median(finite)) > POSITION_TOLERANCE_M:
        state_reasons.append(f"the position given is {np.median(finite):.0f} m from the data's own single-point "
                             f"fix without the named satellites (tolerance {POSITION_TOLERANCE_M:g} m)")
    state = overall_state(states, n_train, state_reasons, present=np.isfinite(ch.bias_s).any(axis=0))
    t_rel = (t_ns - t_ns[0]) / 1e9
    faulty, events = [], []
    for k, text in enumerate(out["identification_events"]):
        for part in filter(None, text.split("; ")):
            kind, rest = part.split(" ", 1)
            sat, reason = rest.split(": ", 1)
            events.append({"t_ns": int(t_ns[k]), "t": float(t_rel[k]), "channel": sat, "kind": kind, "reason": reason})
            if kind == "raise":
                faulty.append({"channel": sat, "t_ns": int(t_ns[k]), "t": float(t_rel[k])})
    alarms = [{"t_ns": int(t_ns[k]), "t": float(t_rel[k]), "statistic": float(out["min_p_alpha"][k]),
               "channel": out["named"][k] or "unidentified"}
              for k in np.flatnonzero(np.asarray(out["identification_state"]) == "alarm")]
    clock_doc = {"state": "untested", "pfa": 0.0, "alarms": [], "reasons": [], "steps": []}
    if clock is not None:
        clock_doc = {"state": "alarm" if clock.alarm.any() else ("ok" if clock.tested.any() else "unavailable"),
                     "pfa": settings.pfa * reserved, "reasons": [clock.reason] if clock.reason else [],
                     "n_tested": int(clock.tested.sum()),
                     "noise": clock.noise.to_json() if clock.noise is not None else None,
                     "steps": [{"t_ns": int(t_ns[k]), "t": float(t_rel[k])} for k in clock.steps],
                     "alarms": [{"t_ns": int(t_ns[k]), "t": float(t_rel[k]), "p": float(clock.p[k])}
                                for k in clock.raised]}
        for k in clock.raised:
            events.append({"t_ns": int(t_ns[k]), "t": float(t_rel[k]), "channel": "receiver clock", "kind": "raise",
                           "reason": f"receiver-clock fault: the clock every satellite shares fails its test "
                                     f"(p {clock.p[k]:.2g} < {settings.pfa * reserved:.2g})"})
            faulty.append({"channel": "receiver clock", "t_ns": int(t_ns[k]), "t": float(t_rel[k])})
    doc = base_document("identification", t_ns.size, window, pfa, alarms, ch.n_skipped_epochs)
    doc.update(availability(state, state_reasons, t_ns, per_epoch, states, n_train))
    doc["warnings"] = [f"{r}: not tested" for r in reasons]
    doc.update({"faulty": sorted(faulty, key=lambda f: (f["t_ns"], f["channel"])),
                "channel_events": sorted(events, key=lambda e: (e["t_ns"], e["channel"])),
                "receiver_clock": clock_doc, "codes": list(ch.codes), "n_channels": len(ch.channels),
                "interval_s": ch.interval_s, "test": test, "t0_gps_ns": int(t_ns[0]),
                "code_noise": {c: n.to_json() for c, n in stage.noise_.items()},
                "untested": sorted(set(ch.codes) - set(stage.noise_)),
                "position_offset_m": float(np.median(finite)) if finite.size else math.nan,
                "station_pfa": {"method": "Bonferroni over the tests of each epoch", "reserved": reserved,
                                "channel_alpha_mean": float(np.mean(out["alpha"][~training]))}})
    return doc, out
