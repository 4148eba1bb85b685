"""Receiver clock steering: whole-millisecond resets found, repaired and reported."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.integrity.clock_events import repair_clock_steering
from chronofuse.io.rinex_clock import read_station_clocks

STEERED = ("MANA", "URUM", "TIXJ")


@pytest.fixture(scope="module")
def igs(real_data):
    return read_station_clocks(real_data / "receivers/rinex/rtklib/igs15904.clk.gz")


def test_a_simulated_reset_of_any_whole_number_of_ms_is_found_at_its_epoch_and_removed():
    rng = np.random.default_rng(1)
    clock = np.cumsum(np.full(200, 3e-7)) + rng.normal(0, 1e-9, 200)
    jumps = {40: 1e-3, 41: -1e-3, 90: -2e-3, 150: 1e-3}
    steered = clock + sum(np.where(np.arange(200) >= k, j, 0.0) for k, j in jumps.items())
    fix = repair_clock_steering(steered)
    assert dict(zip(fix.event_epochs.tolist(), fix.event_size_s.tolist())) == jumps
    np.testing.assert_allclose(fix.repaired_s, clock, atol=1e-12)
    # a 0.3 ms jump is not steering: it is left to the detector
    odd = clock + np.where(np.arange(200) >= 60, 3e-4, 0.0)
    assert repair_clock_steering(odd).event_epochs.size == 0


def test_every_millisecond_reset_of_the_steered_igs_stations_is_a_clock_event_and_nothing_else_is(igs):
    for name in igs.stations:
        x = igs.bias_s[name]
        fix = repair_clock_steering(x)
        d2 = np.diff(fix.repaired_s, 2)
        # after the repair no second difference is anywhere near a millisecond
        assert np.all(np.abs(d2) < 1e-4), name
        raw = np.abs(np.diff(x, 2)) > 5e-4
        assert (fix.event_epochs.size > 0) == raw.any(), name
    for name in STEERED:
        assert repair_clock_steering(igs.bias_s[name]).event_epochs.size >= 5, name


def test_detect_on_a_clock_product_lists_every_station_with_its_clock_events(real_data, igs):
    path = real_data / "receivers/rinex/rtklib/igs15904.clk.gz"
    result = CliRunner().invoke(app, ["detect", str(path), "--window", "5", "--train", "3000", "--json"])
    doc = json.loads(result.stdout)
    assert doc["mode"] == "clock-product" and doc["n_stations"] == 176
    rows = {r["station"]: r for r in doc["stations"]}
    for name in igs.stations:
        expected = repair_clock_steering(igs.bias_s[name]).event_epochs.size
        assert len(rows[name]["clock_events"]) == expected, name
    # MANA, URUM, TIXJ "and five others" steer their clocks
    assert {n for n, r in rows.items() if r["clock_events"]} == {"MANA", "URUM", "TIXJ", "MAL2", "UNBJ", "METS",
                                                                 "OHI2", "LHAZ"}
    # stations with too few epochs to train or fill a window say so instead of "no alarm"
    for name in ("CAGL", "JOZE", "YELL", "LPGS"):
        assert rows[name]["state"] == "unavailable" and rows[name]["unavailable_reasons"], name
    assert all(r["n_tested"] > 0 for r in rows.values() if r["state"] != "unavailable")
    assert result.exit_code == {"ok": 0, "alarm": 1, "unavailable": 3}[doc["state"]]
    one = CliRunner().invoke(app, ["detect", str(path), "--station", "TIXJ", "--window", "5", "--h0", "1e-18",
                                   "--hm2", "1e-28", "--sigma-rho", "1", "--json"])
    tixj = json.loads(one.stdout)
    assert tixj["station"] == "TIXJ" and len(tixj["clock_events"]) == len(rows["TIXJ"]["clock_events"])
    assert {e["kind"] for e in tixj["clock_events"]} == {"clock reset"}


def test_manas_alarms_after_the_repair_come_from_its_oscillators_drift_not_its_resets(igs):
    # docs/integrity/clock_products.md: MANA alarms on its 2 tested epochs although every reset is repaired
    fix = repair_clock_steering(igs.bias_s["MANA"])
    d2 = np.diff(fix.repaired_s, 2)
    assert fix.event_epochs.size == 5 and np.all(np.isfinite(d2))
    # a steady frequency drift: every second difference of one sign, -0.5 to -1.2 us over 300 s intervals;
    # a zero-mean noise model cannot hold it, while the resets themselves (1 ms) are gone
    assert np.all((d2 < -0.5e-6) & (d2 > -1.2e-6))
