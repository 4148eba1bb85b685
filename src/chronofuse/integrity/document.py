"""The detection-mode document of one watched receiver clock: what ``chronofuse detect FILE`` prints with
``--json``, built from a :class:`~chronofuse.integrity.watch.Watched` clock whichever driver watched it (the
batch :func:`~chronofuse.integrity.watch.watch_record` or the live
:class:`~chronofuse.integrity.watch.ClockWatch`), so ``detect FILE`` and ``detect -`` print the same document.

Keys (the states and reasons: :mod:`chronofuse.integrity.modes`): ``alarms`` the tested epochs whose
statistic is over its threshold (``{"t_ns", "t", "statistic", "channel"}``); ``alarm_events`` each raise
and clear of the latched alarm with its reason; ``n_alarm_epochs`` the epochs in a raised alarm;
``clock_events`` the receiver's millisecond resets; ``unavailable`` the untested stretches; ``noise`` the
model used; ``noise_change`` the F test of the tested second differences against the training's;
``warnings``; ``n_no_fix`` and ``n_time_accuracy_over`` the epochs the receiver's status ruled out;
``time_scale`` the axis of every ``t_ns`` (``gps``: GPS ns; ``file``: the file's own time column in ns).
``t`` is ``t_ns`` in seconds, for reading (``t_ns`` is exact).
"""

from __future__ import annotations

import numpy as np

from chronofuse.integrity.availability import availability, overall_state, training_warnings
from chronofuse.integrity.detector import chi2_thresholds
from chronofuse.integrity.receiver_status import NO_FIX
from chronofuse.integrity.stationarity import NOISE_CHANGE_ALPHA, noise_change
from chronofuse.validation import InputDataError

__all__ = ["detection_document", "check_length", "base_document"]

_NO_TEST = "no test (missing epoch or difference chain restarting)"


def check_length(n_epochs: int, window: int, source: str) -> None:
    """Refuse a record too short for one full window (:class:`InputDataError` naming ``source``)."""
    if n_epochs - 2 < window:
        raise InputDataError(f"window {window} is longer than the data: {n_epochs} epochs give {max(n_epochs - 2, 0)} "
                             "differences", source)


def base_document(mode: str, n_epochs: int, window: int, pfa: float, alarms: list[dict], n_skipped: int) -> dict:
    """The keys every detect document has."""
    return {
        "mode": mode,
        "n_epochs": int(n_epochs),
        "threshold": float(chi2_thresholds(pfa, int(window))[-1]),
        "window": int(window),
        "pfa": float(pfa),
        "alarms": alarms,
        "n_alarms": len(alarms),
        "n_skipped": int(n_skipped),
    }


def _noise(det) -> dict | None:
    try:
        return {"h0": float(det.h0_), "hm2": float(det.hm2_), "sigma_rho_m": float(det.sigma_rho_m_),
                "inflation": float(getattr(det, "inflation_", 1.0))}
    except AttributeError:
        return None


def detection_document(watched, settings, *, n_skipped: int, time_scale: str) -> dict:
    """The document of a watched clock (module docstring); ``n_skipped`` missing epochs and damaged frames."""
    r = watched.result
    t_ns = np.asarray(r["t_ns"], dtype=np.int64)
    n = t_ns.size
    training = watched.training
    n_train = watched.n_training
    after = ~training
    status = np.asarray(r["status"], dtype=object)
    bad_status = status != ""
    tested = (np.asarray(r["dof"]) > 0) & after & watched.fitted
    over = np.asarray(r["over"], dtype=bool) & tested
    latched = np.asarray(r["state"], dtype=object)
    per_epoch = np.full(n, "", dtype=object)
    per_epoch[training] = "training"
    reasons = list(watched.reasons)
    warnings: list[str] = []
    if watched.fitted:
        per_epoch[~tested & after] = _NO_TEST
        per_epoch[bad_status & after] = status[bad_status & after]
    else:
        per_epoch[:] = "training failed"
    states = np.where(tested, np.where(latched == "alarm", "alarm", "ok"), "unavailable").astype(object)
    x = np.asarray(r["detector_input_s"], dtype=np.float64)
    if watched.fitted and settings.trains:
        left_out = np.flatnonzero(np.isin(t_ns, watched.outlier_t_ns))
        if left_out.size:
            warnings.append(f"training outliers: {left_out.size} epoch(s) left out of the noise fit (t_ns "
                            f"{', '.join(str(int(t_ns[k])) for k in left_out[:5])}{', ...' if left_out.size > 5 else ''})")
        warnings.extend(training_warnings(np.diff(x[:n_train], 2) / watched.interval_s))
    state = overall_state(states, n_train, reasons, present=np.isfinite(np.asarray(r["repaired_bias_s"])))
    alarms = [{"t_ns": int(t_ns[k]), "t": t_ns[k] / 1e9, "statistic": float(r["statistic"][k]), "channel": None}
              for k in np.flatnonzero(over)]
    doc = base_document("detection", n, settings.window, settings.pfa, alarms, n_skipped)
    doc.update(availability(state, reasons, t_ns, per_epoch, states, n_train))
    resets = np.asarray(r["clock_reset_s"], dtype=np.float64)
    doc["clock_events"] = [{"t_ns": int(t_ns[k]), "t": t_ns[k] / 1e9, "size_s": float(resets[k]), "kind": "clock reset"}
                           for k in np.flatnonzero(resets != 0)]
    events = np.asarray(r["latch_event"], dtype=object)
    doc["alarm_events"] = [{"t_ns": int(t_ns[k]), "kind": str(events[k]).split(":", 1)[0],
                            "reason": str(events[k]).split(": ", 1)[1]} for k in np.flatnonzero(events != "")]
    doc["n_alarm_epochs"] = int((latched == "alarm").sum()) if watched.fitted else 0
    doc["interval_s"] = float(watched.interval_s)
    doc["time_scale"] = time_scale
    doc["noise"] = _noise(watched.detector) if watched.fitted else None
    doc["noise_change"] = None
    if watched.fitted and settings.trains and hasattr(watched.detector, "r_"):  # a detector with a noise model
        df = np.full(n, np.nan)
        df[2:] = np.diff(x, 2) / watched.interval_s
        ratio, p_value = noise_change(df[:n_train], np.where(tested, df, np.nan)[n_train:],
                                      watched.detector.r_ / getattr(watched.detector, "inflation_", 1.0))
        doc["noise_change"] = {"ratio": ratio, "p_value": p_value}
        if p_value < NOISE_CHANGE_ALPHA:
            warnings.append(f"noise changed after training: the tested differences' mean square is {ratio:.3g} times "
                            f"the training's (F test p = {p_value:.2g}); alarms may be the noise model going stale")
    doc["warnings"] = warnings
    doc["n_no_fix"] = int((status == NO_FIX).sum())
    doc["n_time_accuracy_over"] = int((bad_status & (status != NO_FIX)).sum())
    doc["max_time_acc_s"] = settings.max_time_acc_s
    return doc
