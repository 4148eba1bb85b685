"""A RINEX clock product in detection mode: one row of verdicts per station, and the false-alarm summary over
the stations with no event (:mod:`chronofuse.integrity.stationarity`). ``chronofuse detect FILE.clk``
without a station. Each station's clock runs through the same detection pipeline as any other clock
(:func:`chronofuse.integrity.watch.watch_record`)."""

from __future__ import annotations

from chronofuse.integrity.detector import chi2_thresholds
from chronofuse.integrity.document import check_length, detection_document
from chronofuse.integrity.stationarity import false_alarm_summary
from chronofuse.integrity.watch import DetectionSettings, watch_record
from chronofuse.io.clockbias import n_skipped
from chronofuse.validation import InputDataError

__all__ = ["clock_product_document", "station_row", "product_document"]


def station_row(name: str, record, settings: DetectionSettings, watched=None, source: str = "") -> dict:
    """One station's row: its verdicts, or ``unavailable`` with the reason when it is too short for the window
    or the training (or has one epoch: nothing to difference). ``record`` is the station's gridded clock bias
    (None: one epoch); ``watched`` a clock the live driver already watched (else the batch driver runs);
    ``source`` the product, named with the station in a reason."""
    row = {"station": name, "n_epochs": 1 if record is None else int(record.n_epochs),
           "interval_s": float("nan") if record is None else record.interval_s}
    where = f"{source or (record.source if record is not None else '')} {name}".strip()
    try:
        if record is None:
            raise InputDataError("one epoch: nothing to difference", where)
        check_length(record.n_epochs, settings.window, where)
        watched = watch_record(record, settings) if watched is None else watched
        doc = detection_document(watched, settings, n_skipped=n_skipped(record), time_scale=record.time_scale)
    except InputDataError as err:
        row.update(state="unavailable", n_tested=0, n_alarms=0, clock_events=[], unavailable_reasons=[str(err)])
    else:
        row.update(state=doc["state"], n_tested=doc["n_tested"], n_alarms=doc["n_alarms"],
                   clock_events=doc["clock_events"], unavailable_reasons=doc["unavailable_reasons"],
                   noise=doc["noise"], warnings=doc["warnings"], noise_change=doc["noise_change"])
    return row


def product_document(rows: list[dict], settings: DetectionSettings, *, n_bad_lines: int, source: str) -> dict:
    """The clock-product document of station rows: the overall state is ``alarm`` when a station alarms,
    ``unavailable`` when no station could be tested, else ``ok``; with a training stretch, ``false_alarms`` is
    :func:`chronofuse.integrity.stationarity.false_alarm_summary` of the rows."""
    states = {r["state"] for r in rows}
    state = "alarm" if "alarm" in states else ("ok" if "ok" in states else "unavailable")
    return {
        "mode": "clock-product",
        "state": state,
        "n_stations": len(rows),
        "threshold": float(chi2_thresholds(settings.pfa, int(settings.window))[-1]),
        "window": int(settings.window),
        "pfa": float(settings.pfa),
        "stations": rows,
        "false_alarms": false_alarm_summary(rows, settings.pfa) if settings.trains else None,
        "n_bad_lines": int(n_bad_lines),
        "source": source,
    }


def clock_product_document(clocks, settings: DetectionSettings) -> dict:
    """Every station of a RINEX clock product (:class:`chronofuse.io.rinex_clock.StationClocks`) in detection
    mode: one row of verdicts per station (:func:`station_row`), each on its own interval."""
    from chronofuse.io.rinex_clock import station_clock_bias

    rows = []
    for name in clocks.stations:
        record = None if clocks.gps_ns[name].size < 2 else station_clock_bias(clocks, name)
        rows.append(station_row(name, record, settings, source=clocks.source))
    return product_document(rows, settings, n_bad_lines=clocks.n_bad_lines, source=clocks.source)
