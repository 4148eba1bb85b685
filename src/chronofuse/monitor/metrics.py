"""``/metrics``: the status document in the Prometheus text exposition format, written by
prometheus_client (one series per receiver and quantity, label ``receiver``).

Gauges per receiver: link up, usable, stale, age of the last epoch (s), fix mode, satellites, GDOP,
clock bias (s), clock drift (s/s), qErr (s), GPS - UTC (s), alarm (no sample while untested), integrity tested, dissent; counters per receiver:
epochs, alarm epochs, outages; and the monitor's acknowledged epochs and time-server samples. A quantity
a receiver has not reported (NaN, or one its kind of source cannot give) has no sample: an absent series
is "unknown", never a made-up zero.
"""

from __future__ import annotations

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily

__all__ = ["metrics_text", "CONTENT_TYPE", "GAUGES", "COUNTERS"]

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"

#: (metric name, help, how to read it from a receiver entry of the status document)
GAUGES = (
    ("chronofuse_receiver_up", "1 when the receiver's link is up", lambda r: float(r["link"] == "up")),
    ("chronofuse_receiver_usable", "1 when its time is usable (every condition of the verdict met)",
     lambda r: None if r["usable"] is None else float(r["usable"])),
    ("chronofuse_receiver_stale", "1 when no epoch came for longer than the stale time", lambda r: float(r["stale"])),
    ("chronofuse_receiver_age_seconds", "age of its last epoch", lambda r: r["age_s"]),
    ("chronofuse_receiver_fix_mode", "gpsd fix mode: 0 unknown, 1 none, 2 2-D, 3 3-D or time-only",
     lambda r: _last(r, "fix_mode")),
    ("chronofuse_receiver_satellites", "satellites used", lambda r: _last(r, "n_sats", minimum=0)),
    ("chronofuse_receiver_gdop", "geometric dilution of precision", lambda r: _last(r, "gdop")),
    ("chronofuse_receiver_clock_bias_seconds", "receiver clock bias against GNSS time", lambda r: _last(r, "clock_bias_s")),
    ("chronofuse_receiver_clock_drift_seconds_per_second", "receiver clock drift",
     lambda r: _last(r, "clock_drift_s_per_s")),
    ("chronofuse_receiver_qerr_seconds", "quantization error of the coming 1PPS edge", lambda r: _last(r, "qerr_s")),
    ("chronofuse_receiver_gps_minus_utc_seconds", "GPS - UTC the receiver announces", lambda r: _last(r, "leap_s")),
    ("chronofuse_receiver_alarm", "1 while the clock-bias integrity alarm is raised (latched); no sample while "
     "the test has not tested the receiver's epochs (training, training failed, no clock bias)", lambda r: _alarm(r)),
    ("chronofuse_receiver_integrity_tested", "1 when the integrity test tested its last epoch", lambda r: _tested(r)),
    ("chronofuse_receiver_dissent", "1 while its UTC or leap count disagrees", lambda r: _last(r, "dissent")),
)
COUNTERS = (
    ("chronofuse_receiver_epochs", "epochs decided", lambda r: r["epochs"]),
    ("chronofuse_receiver_alarm_epochs", "epochs in alarm", lambda r: r["alarms"]),
    ("chronofuse_receiver_outages", "link outages", lambda r: r["outages"]),
    ("chronofuse_receiver_reordered_epochs", "epochs put back in time order", lambda r: r["reordered"]),
    ("chronofuse_receiver_late_epochs", "epochs that came too late, left out", lambda r: r["late"]),
)


def _tested(entry: dict):
    last = entry["last"]
    return None if last is None else float(last.get("state") in ("ok", "alarm"))


def _alarm(entry: dict):
    """1 in alarm, 0 only when tested and found without one: an untested epoch is not "no alarm"."""
    last = entry["last"]
    if last is None:
        return None
    if last.get("state") == "alarm" or last.get("alarm"):
        return 1.0
    return 0.0 if last.get("state") == "ok" else None


def _last(entry: dict, key: str, minimum: float | None = None):
    last = entry["last"]
    if last is None or last.get(key) is None:
        return None
    value = float(last[key])
    return None if minimum is not None and value < minimum else value


class _StatusCollector:
    def __init__(self, doc: dict) -> None:
        self.doc = doc

    def collect(self):
        receivers = self.doc["receivers"]
        for name, text, read in GAUGES:
            family = GaugeMetricFamily(name, text, labels=["receiver"])
            for r in receivers:
                value = read(r)
                if value is not None:
                    family.add_metric([r["receiver"]], value)
            yield family
        for name, text, read in COUNTERS:
            family = CounterMetricFamily(name, text, labels=["receiver"])
            for r in receivers:
                family.add_metric([r["receiver"]], float(read(r)))
            yield family
        acked = CounterMetricFamily("chronofuse_epochs_acknowledged", "epochs committed to the log and acknowledged")
        acked.add_metric([], float(self.doc["acknowledged"]))
        yield acked
        chrony = self.doc.get("chrony")
        if chrony is not None:
            sent = CounterMetricFamily("chronofuse_chrony_samples", "samples sent to chronyd's SOCK refclock")
            sent.add_metric([], float(chrony["samples_sent"]))
            yield sent


def metrics_text(doc: dict) -> bytes:
    """The Prometheus text exposition of a status document (:func:`chronofuse.monitor.status.status_document`)."""
    registry = CollectorRegistry(auto_describe=False)
    registry.register(_StatusCollector(doc))
    return generate_latest(registry)
