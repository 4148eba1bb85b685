"""Position-domain integrity of a RINEX observation file whose receiver position is not known: the document of
``chronofuse detect OBS --nav NAV --raim``.

The single-point solution's own measurements (:func:`chronofuse.gnss.point_positioning.point_positions`, its
outlier screen off: integrity monitoring is the screen) go through :func:`chronofuse.integrity.raim.raim`:
pseudoranges corrected for satellite clock, Klobuchar ionosphere and Saastamoinen troposphere, with the
solution's 1-sigma model (code, ionosphere and troposphere residual, the broadcast URA) as the fault-free
sigma.

Document keys: those of every detect document (``mode`` ``raim``, ``state``, ``alarms``, ...);
``epoch_states`` (count per state of :data:`chronofuse.integrity.raim.STATES`); ``availability`` (share of
epochs ``ok`` or ``excluded``); ``hpl_m``/``vpl_m`` (median, 95th percentile and largest over the available
epochs); ``mdb_m`` (median and 95th percentile of every used satellite's minimum detectable bias at
``p_md``); ``p_md``, ``integrity_risk``, alert limits; ``time_to_alert_s`` (0: an alarm is given at the epoch
whose measurements carry the fault); with a known ``position_m``, ``position_check``: the horizontal and
vertical errors of the declared solution and how many available epochs had an error beyond their level,
with a Clopper-Pearson 95 % interval on that rate. Overall state: ``alarm`` when an epoch is in ``alarm``
or ``excluded``, ``unavailable`` when fewer than half the epochs are available, else ``ok``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from chronofuse.analysis.metrics import clopper_pearson
from chronofuse.integrity.raim import STATES, RaimSettings, raim
from chronofuse.validation import InputDataError, check_scalar

__all__ = ["raim_document"]


def raim_document(obs_path, nav_paths, *, settings: RaimSettings | None = None, position_m=None,
                  elevation_mask_deg: float = 10.0, systems=None, observations=None, navigation=None,
                  epoch_step: int = 1) -> dict:
    """Position-domain integrity of ``obs_path`` with the navigation file(s) ``nav_paths`` (module docstring);
    ``systems``: letters (default: GPS and Galileo where the navigation has them, else what it has);
    ``observations``/``navigation``: already read (skips the reading); ``epoch_step``: every so many epochs."""
    from chronofuse.gnss.lsq_position import _enu_rotation
    from chronofuse.gnss.point_positioning import SppOptions, point_positions
    from chronofuse.integrity.availability import overall_state
    from chronofuse.integrity.document import base_document
    from chronofuse.integrity.inputs import parse_position
    from chronofuse.io.rinex_nav import merge_navigation, read_navigation
    from chronofuse.io.rinex_obs import read_any_observations

    cfg = settings or RaimSettings()
    known = parse_position(position_m) if position_m is not None else None
    check_scalar(epoch_step, "epoch_step", min_val=1, integer=True)
    if navigation is None:
        paths = [nav_paths] if isinstance(nav_paths, (str, Path)) else list(nav_paths)
        navigation = merge_navigation([read_navigation(p) for p in paths])
    nav = navigation
    obs = observations if observations is not None else read_any_observations(obs_path)
    if epoch_step > 1:
        obs = obs.select(slice(0, None, int(epoch_step)))
    if systems is None:
        systems = tuple(s for s in ("G", "E") if s in nav.systems and s in obs.systems) or tuple(nav.systems[:1])
    fix = point_positions(obs, nav, systems=systems,
                          options=SppOptions(elevation_mask_deg=elevation_mask_deg, max_exclusions=0))
    if not np.isfinite(fix.corrected_m).any():
        raise InputDataError(f"the navigation data give no usable {'+'.join(systems)} satellite at any epoch of "
                             "the observations (a navigation file of another day?)", str(nav.source or nav_paths))
    start = np.asarray(obs.header.approx_position_m) if obs.header.approx_position_m is not None else np.zeros(3)
    x0 = np.where(np.isfinite(fix.position_m), fix.position_m, start)
    res = raim(fix.satellite_m, fix.corrected_m, fix.sigma_m, fix.system_index, x0, cfg)
    t_ns = np.asarray(obs.gps_ns)
    t_rel = (t_ns - t_ns[0]) / 1e9
    flagged = np.isin(res.state, ("alarm", "excluded"))
    alarms = [{"t_ns": int(t_ns[k]), "t": float(t_rel[k]), "statistic": float(res.max_statistic[k]),
               "channel": fix.satellites[res.excluded[k]] if res.excluded[k] >= 0 else "unidentified",
               "state": str(res.state[k])} for k in np.flatnonzero(flagged)]
    usable = np.isin(res.state, ("ok", "excluded"))
    per_epoch = np.where(res.state == "unavailable", "too few satellites or a protection level over its alert limit",
                         "")
    reasons: list[str] = []
    mapped = np.where(res.state == "excluded", "alarm", res.state).astype(object)
    state = overall_state(mapped, 0, reasons)
    if flagged.any():  # a fault detected (excluded or not) is the verdict, however few epochs were available
        state = "alarm"
    doc = base_document("raim", t_ns.size, 1, cfg.pfa, alarms, 0)
    doc.pop("threshold")
    doc.pop("window")
    doc.update({"state": state, "unavailable_reasons": reasons, "n_tested": int(usable.sum() + (res.state == "alarm").sum()),
                "n_training": 0, "warnings": [],
                "unavailable": [{"from_ns": int(t_ns[k]), "to_ns": int(t_ns[k]), "reason": str(per_epoch[k])}
                                for k in np.flatnonzero(per_epoch != "")],
                "systems": list(systems), "epoch_states": {s: int((res.state == s).sum()) for s in STATES},
                "availability": float(usable.mean()) if usable.size else 0.0,
                "integrity_risk": cfg.integrity_risk, "p_md": cfg.p_md,
                "horizontal_alert_limit_m": cfg.horizontal_alert_limit_m,
                "vertical_alert_limit_m": cfg.vertical_alert_limit_m, "time_to_alert_s": 0.0,
                "hpl_m": _summary(res.hpl_m[usable]), "vpl_m": _summary(res.vpl_m[usable]),
                "mdb_m": _summary(res.mdb_m[np.isfinite(res.mdb_m) & usable[:, None]]),
                "excluded": sorted({a["channel"] for a in alarms if a["state"] == "excluded"}),
                "warnings": [] if state != "unavailable" else ["no fault was detected; too few epochs could be tested"]})
    if known is not None:
        err = np.einsum("ij,ej->ei", _enu_rotation(known), res.position_m - known)
        h, v = np.hypot(err[:, 0], err[:, 1]), np.abs(err[:, 2])
        beyond = usable & ((h > res.hpl_m) | (v > res.vpl_m))
        n, k = int(usable.sum()), int(beyond.sum())
        if n and k > 0.05 * n:
            doc["warnings"].append(f"{k} of {n} available epochs have an error beyond their protection level against "
                                   "the position given: the position is wrong, or the fault model does not hold")
        doc["position_check"] = {"n_epochs": n, "n_beyond_level": k,
                                 "rate": k / n if n else math.nan,
                                 "rate_ci95": list(clopper_pearson(k, n, level=0.95)) if n else [math.nan, math.nan],
                                 "horizontal_error_m": _summary(h[usable]), "vertical_error_m": _summary(v[usable])}
    return doc


def _summary(values: np.ndarray) -> dict:
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": math.nan, "p95": math.nan, "max": math.nan}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max())}
