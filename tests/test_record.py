"""The one epoch record: integer time tags, named columns with units, a validity mask, provenance; chunks of a
stream join back into the record; every reader and simulator gives it."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.record import EpochRecord, Provenance

from _helpers import receivers_dir  # noqa: E402

RX = receivers_dir()


def _record(n=10, **kw):
    t = 1_000_000_007 + np.arange(n, dtype=np.int64) * 10**9
    return EpochRecord.from_arrays(t, {"clock_bias_s": np.arange(n) * 1e-9}, {"clock_bias_s": "s"}, source="x.csv",
                                   position=np.arange(2, n + 2), position_unit="line", **kw)


def test_a_record_refuses_float_times_a_column_without_unit_and_times_that_go_back():
    with pytest.raises(ValueError, match="int64"):
        EpochRecord.from_arrays(np.array([0.0, 1.0]), {"a_s": np.zeros(2)}, {"a_s": "s"}, source="x")
    with pytest.raises(ValueError, match="no unit"):
        EpochRecord.from_arrays(np.array([0, 1]), {"a_s": np.zeros(2)}, {}, source="x")
    with pytest.raises(ValueError, match="unit of a_s"):
        EpochRecord.from_arrays(np.array([0, 1]), {"a_s": np.zeros(2)}, {"a_s": "seconds"}, source="x")
    with pytest.raises(ValueError, match="strictly increasing"):
        EpochRecord.from_arrays(np.array([0, 5, 5]), {"a_s": np.zeros(3)}, {"a_s": "s"}, source="x")


def test_its_arrays_are_read_only_and_its_chunks_join_back_exactly():
    rec = _record(25)
    assert not rec.t_ns.flags.writeable and not rec.columns["clock_bias_s"].flags.writeable
    for size in (1, 4, 25, 100):
        joined = EpochRecord.concat(rec.chunks(size))
        np.testing.assert_array_equal(joined.t_ns, rec.t_ns)
        np.testing.assert_array_equal(joined.columns["clock_bias_s"], rec.columns["clock_bias_s"])
        np.testing.assert_array_equal(joined.provenance.position, rec.provenance.position)


def test_provenance_names_the_line_the_byte_or_the_index_of_an_epoch():
    assert _record().provenance.where(3) == "x.csv:5"
    assert Provenance("<stdin>", "byte", np.array([0, 731])).where(1) == "<stdin>@731"
    assert Provenance("sim", "index", np.array([-1, 4])).where(0) == "sim"


def test_a_column_the_record_lacks_is_named_with_the_ones_it_has():
    with pytest.raises(KeyError, match="has no column 'qerr_s'.*clock_bias_s"):
        _record().column("qerr_s")
    assert np.isnan(_record().column("qerr_s", np.nan)).all()


def test_a_ubx_capture_gives_a_record_whose_epochs_point_at_their_first_frame():
    from chronofuse.io.inspect import read_capture

    path = RX / "gpsd" / "navisys-gr701w.log"
    capture = read_capture(path)
    record = capture.record()
    data = path.read_bytes()
    assert record.time_scale == "gps" and record.provenance.unit == "byte" and record.n_epochs == capture.n_epochs
    for k in range(record.n_epochs):
        offset = int(record.provenance.position[k])
        assert data[offset : offset + 3] == b"\xb5\x62\x01"  # a UBX navigation frame starts there
        tow_ms = int.from_bytes(data[offset + 6 : offset + 10], "little")
        assert tow_ms * 10**6 == int(record.t_ns[k]) % (604_800 * 10**9)
    np.testing.assert_array_equal(record.valid, capture.rows["fix_mode"] != 1)


def test_a_simulated_clock_and_simulated_receivers_give_records():
    from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
    from chronofuse.models.environment import receiver_environment
    from chronofuse.models.receiver import simulate_receivers

    sim = simulate_clock_bias(ClockNoise(h0=1e-18, hm2=1e-22, sigma_rho_m=1.0), interval_s=30.0, steps=20, trials=3,
                              seed=1)
    rec = sim.record(t0_ns=7)
    assert rec.lead == (3,) and rec.interval_ns == 30 * 10**9 and rec.t_ns[1] == 7 + 30 * 10**9
    truth = simulate_receivers(receiver_environment("open-sky"), 60, 2, seed=4, trials=2)
    r = truth.record()
    assert r.lead == (2, 2) and r.time_scale == "gps"
    np.testing.assert_array_equal(r.column("clock_bias_s"), truth.epochs.clock_bias_s)
