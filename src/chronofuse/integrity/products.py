"""A RINEX clock product in detection mode: one row of verdicts per station, and the false-alarm summary over
the stations with no event (:mod:`chronofuse.integrity.stationarity`). ``chronofuse detect FILE.clk``
without a station."""

from __future__ import annotations

import numpy as np

from chronofuse.integrity.detector import HodDetector, chi2_thresholds
from chronofuse.integrity.modes import detection_document
from chronofuse.integrity.stationarity import false_alarm_summary
from chronofuse.validation import InputDataError


def clock_product_document(clocks, params: dict, train_s: float | None = None) -> dict:
    """Every station of a RINEX clock product in detection mode: one row of verdicts per station.

    ``params``: the :class:`HodDetector` parameters but the interval (each station's own). A station too
    short for the window or the training is ``unavailable`` with its reason, not an error. The overall
    state is ``alarm`` when a station alarms, ``unavailable`` when no station could be tested, else ``ok``.
    Each row has the station's ``noise_change`` (after training); with ``train_s``, ``false_alarms`` is
    :func:`chronofuse.integrity.stationarity.false_alarm_summary` of the rows.
    """
    from chronofuse.io.rinex_clock import station_clock_bias

    rows = []
    for name in clocks.stations:
        data = station_clock_bias(clocks, name)
        row = {"station": name, "n_epochs": int(data.bias_s.size), "interval_s": float(data.interval_s)}
        try:
            if not np.isfinite(data.interval_s):
                raise InputDataError("one epoch: nothing to difference", data.source)
            doc = detection_document(data, HodDetector(interval_s=data.interval_s, **params), train_s)
        except InputDataError as err:
            row.update(state="unavailable", n_tested=0, n_alarms=0, clock_events=[], unavailable_reasons=[str(err)])
        else:
            row.update(state=doc["state"], n_tested=doc["n_tested"], n_alarms=doc["n_alarms"],
                       clock_events=doc["clock_events"], unavailable_reasons=doc["unavailable_reasons"],
                       noise=doc["noise"], warnings=doc["warnings"], noise_change=doc["noise_change"])
        rows.append(row)
    states = {r["state"] for r in rows}
    state = "alarm" if "alarm" in states else ("ok" if "ok" in states else "unavailable")
    det = HodDetector(interval_s=1.0, **params)
    return {
        "mode": "clock-product",
        "state": state,
        "n_stations": len(rows),
        "threshold": float(chi2_thresholds(det.pfa, int(det.window))[-1]),
        "window": int(det.window),
        "pfa": float(det.pfa),
        "stations": rows,
        "false_alarms": false_alarm_summary(rows, det.pfa) if train_s is not None else None,
        "n_bad_lines": int(clocks.n_bad_lines),
        "source": clocks.source,
    }


__all__ = ["clock_product_document"]
