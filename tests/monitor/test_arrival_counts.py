"""The monitor reports, per receiver, the epochs its reorder buffer put back in order and the ones it left out
as late (chronofuse.io.arrival): in the status document (and its schema), the metrics and the live table."""

from __future__ import annotations

import jsonschema

from rich.console import Console

from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.io.inspect import read_bytes
from chronofuse.io.sources import FileSource
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.metrics import metrics_text
from chronofuse.monitor.status import load_schema, status_document
from chronofuse.monitor.table import receiver_table

from .conftest import ubx_epochs

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)
SETTINGS = MonitorSettings(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m, train_s=20.0)


def _epochs() -> list[bytes]:
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=60, trials=1, seed=5).measured_s[0]
    return ubx_epochs(x)


def _shuffled() -> bytes:
    epochs = _epochs()
    epochs[10], epochs[11] = epochs[11], epochs[10]  # one epoch after a later one: put back
    epochs[30:33] = [epochs[31], epochs[32], epochs[30]]  # two epochs late: put back
    late = epochs.pop(45)
    epochs.insert(49, late)  # four epochs late, beyond the buffer: left out
    return b"".join(epochs)


def _monitor(tmp_path, streams: dict[str, bytes]) -> Monitor:
    sources = []
    for name, data in streams.items():
        path = tmp_path / f"{name}.ubx"
        path.write_bytes(data)
        sources.append(FileSource(path, name=name, chunk=997))
    mon = Monitor(sources, SETTINGS)
    mon.run(duration_s=60)
    return mon


def test_swapped_and_very_late_epochs_are_counted_per_receiver_in_the_status_document(tmp_path):
    shuffled = _shuffled()
    batch = read_bytes([shuffled], "<batch>")
    assert (batch.reordered_epochs, batch.late_epochs) == (2, 1)  # what the batch reader counts on the same bytes
    mon = _monitor(tmp_path, {"shuffled": shuffled, "in-order": b"".join(_epochs())})
    doc = status_document(mon)
    jsonschema.validate(doc, load_schema())
    rows = {r["receiver"]: r for r in doc["receivers"]}
    assert (rows["shuffled"]["reordered"], rows["shuffled"]["late"]) == (2, 1)
    assert (rows["in-order"]["reordered"], rows["in-order"]["late"]) == (0, 0)
    assert rows["shuffled"]["epochs"] == 59 and rows["in-order"]["epochs"] == 60  # the late one is not decided
    text = metrics_text(doc).decode()
    assert 'chronofuse_receiver_late_epochs_total{receiver="shuffled"} 1.0' in text
    assert 'chronofuse_receiver_reordered_epochs_total{receiver="in-order"} 0.0' in text
    console = Console(record=True, width=220)
    console.print(receiver_table(mon, doc=doc))
    lines = {ln.split()[0]: ln for ln in console.export_text().splitlines() if ln.split()}
    assert "late 1" in lines["shuffled"] and "late" not in lines["in-order"]


def test_the_schema_requires_the_counts_and_refuses_a_negative_one(tmp_path):
    doc = status_document(_monitor(tmp_path, {"rx": b"".join(_epochs()[:30])}))
    schema = load_schema()
    jsonschema.validate(doc, schema)
    entry = doc["receivers"][0]
    for bad in ({k: v for k, v in entry.items() if k != "late"}, {**entry, "reordered": -1}):
        try:
            jsonschema.validate({**doc, "receivers": [bad]}, schema)
        except jsonschema.ValidationError:
            continue
        raise AssertionError(f"the schema took {bad}")

