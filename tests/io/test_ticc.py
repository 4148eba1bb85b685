"""TAPR TICC logs in the layout its firmware writes (github.com/tapr/TICC, ``TICC.ino`` and ``misc.cpp``,
BSD-2-Clause): ``#`` banner and configuration lines, the mode's heading, then one reading a line printed
exactly from integer picoseconds (``print_timestamp`` / ``print_signed_picos_as_seconds``: seconds, a
point, 12 decimals, ``" chA"``; ``" TI(A->B)"`` in interval mode; newer firmware zero-pads the seconds to
``WRAP`` digits and keeps only those). No public TICC log was found (searched: code and pages), so the
logs are written here from known phase values, which are the oracle."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from chronofuse.io.records import read_record
from chronofuse.io.ticc import nominal_period
from chronofuse.validation import InputDataError

BANNER = ("\n# TAPR TICC Timestamping Counter\n# Copyright 2016-2020 N8UR, K9TRV, NH6Z, WA8YWQ\n\n"
          "#####################\n# TICC Configuration: \n#####################\n\n\n\n")


def _ps_text(ps: int, wrap: int = 0) -> str:
    """The firmware's print of integer picoseconds (non-negative timestamps; ``wrap`` integer digits)."""
    sec, frac = divmod(abs(ps), 10**12)
    head = f"{sec:010d}"[10 - wrap:] if wrap else str(sec)
    return ("-" if ps < 0 else "") + f"{head}.{frac:012d}"


def _phase_ps(n: int, seed: int) -> np.ndarray:
    """A phase record in integer ps: white FM of 1e-11 plus a 2e-12 s/s frequency offset."""
    rng = np.random.default_rng(seed)
    return np.rint(np.cumsum(rng.normal(0, 10.0, n)) + 2.0 * np.arange(n)).astype(np.int64)


def _quietly(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read_record(path, **kw)


def test_one_channel_of_timestamps_is_the_phase_against_the_ticc_clock(tmp_path):
    x = _phase_ps(600, 1)
    start = 8_737_740_891_687  # the TICC counts from its start: 8.737... s
    path = tmp_path / "ticc.log"
    path.write_text(BANNER + "# timestamp (seconds with 12 decimal places)\n"
                    + "".join(f"{_ps_text(start + k * 10**12 + int(v))} chA\n" for k, v in enumerate(x)))
    rec = _quietly(path)
    assert rec.kind == "phase" and rec.rate_hz == 1.0 and rec.values.size == 600 and rec.n_gaps == 0
    np.testing.assert_allclose(rec.values, (x - x[0]) * 1e-12, rtol=0, atol=1e-16)
    assert rec.t_ns[0] == start // 1000 and rec.t_ns[1] - rec.t_ns[0] == 1_000_000_000
    assert any("TICC" in n for n in rec.notes)


def test_a_missed_pulse_is_a_gap_and_wrapped_seconds_are_unwrapped(tmp_path):
    x = _phase_ps(300, 2)
    keep = np.ones(300, bool)
    keep[100] = False
    start = 95 * 10**12 + 123_456_789
    path = tmp_path / "wrap.log"
    path.write_text("# timestamp (seconds with 12 decimal places)\n" + "".join(
        f"{_ps_text((start + k * 10**12 + int(v)) % (100 * 10**12), wrap=2)} chA\n"
        for k, v in enumerate(x) if keep[k]))
    assert "00." in path.read_text()
    rec = _quietly(path)
    assert rec.values.size == 300 and rec.n_gaps == 1 and np.isnan(rec.values[100])
    np.testing.assert_allclose(rec.values[keep], (x[keep] - x[0]) * 1e-12, rtol=0, atol=1e-16)


def test_two_channels_give_cha_minus_chb_matched_per_pulse_and_a_lone_pulse_is_warned(tmp_path):
    xa, xb = _phase_ps(400, 3), _phase_ps(400, 4) + 100_000  # chB 100 ns after chA
    start = 2 * 10**12
    lines = []
    for k in range(400):
        lines.append(f"{_ps_text(start + k * 10**12 + int(xa[k]))} chA\n")
        if k != 250:
            lines.append(f"{_ps_text(start + k * 10**12 + int(xb[k]))} chB\n")
    path = tmp_path / "ab.log"
    path.write_text(BANNER + "# timestamp (seconds with 12 decimal places)\n" + "".join(lines))
    with pytest.warns(UserWarning, match=r"1 chA and 0 chB pulses have no partner within half a period \(the first at line \d+\)"):
        rec = read_record(path)
    expected = (xa - xb) * 1e-12
    expected[250] = np.nan
    np.testing.assert_allclose(rec.values, expected, rtol=0, atol=1e-16)
    assert rec.column == "chA - chB" and rec.n_gaps == 1
    alone = _quietly(path, column="chB")
    assert alone.values.size == 400 and np.isnan(alone.values[250])


def test_time_interval_mode_is_one_phase_sample_a_line(tmp_path):
    ti = 100_000 + _phase_ps(200, 5) - 400
    path = tmp_path / "ti.log"
    path.write_text("# time interval A->B (seconds with 12 decimal places)\n"
                    + "".join(f"{_ps_text(int(v))} TI(A->B)\n" for v in ti))
    with pytest.warns(UserWarning, match="read at 1 Hz"):
        rec = read_record(path)
    np.testing.assert_allclose(rec.values, ti * 1e-12, rtol=0, atol=1e-16)
    assert _quietly(path, rate_hz=10.0).rate_hz == 10.0


def test_period_mode_sums_the_periods_less_the_nominal(tmp_path):
    x = _phase_ps(100, 6)
    path = tmp_path / "period.log"
    path.write_text("# period (seconds with 12 decimal places)\n"
                    + "".join(f"{_ps_text(10**12 + int(d))} chA\n" for d in np.diff(x)))
    rec = _quietly(path)
    np.testing.assert_allclose(rec.values, (x - x[0]) * 1e-12, rtol=0, atol=1e-16)


def test_a_damaged_ticc_line_or_a_restart_is_refused_naming_the_line(tmp_path):
    path = tmp_path / "bad.log"
    path.write_text("# timestamp (seconds)\n1.000000000000 chA\n2.000000000001 chA\n3.0000 garbage\n")
    with pytest.raises(InputDataError, match=r"bad.log:4: '3.0000 garbage' is no TICC timestamp reading"):
        read_record(path)
    path.write_text("# timestamp (seconds)\n51.000000000000 chA\n52.000000000001 chA\n3.000000000000 chA\n")
    with pytest.raises(InputDataError, match=r"bad.log:4: .*goes back \(a restart"):
        read_record(path)


@pytest.mark.parametrize(("step", "nominal"), [(1.0000001, 1.0), (0.0999, 0.1), (2.004, 2.0), (1.3, None)])
def test_the_nominal_period_is_the_nearest_1_2_5_value(step, nominal):
    assert nominal_period(step) == nominal
