"""Latched channel faults: raised when identification names a channel, cleared (with a reason) when it is
consistent with the other channels again, on the real Trimble stations."""

import numpy as np
import pytest

from chronofuse.gnss.observables import channel_clock_biases_from_arrays
from chronofuse.integrity.channel_latch import ChannelLatch, latch_channels
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.identification import identify
from chronofuse.integrity.inject import Anomaly, inject

from _helpers import TRIMBLE_STATIONS

STATIONS = TRIMBLE_STATIONS
ONSET_S, END_S, STEP_S = 1800.0, 2700.0, 100e-9


@pytest.fixture(scope="module")
def real(trimble):
    return {station: biases for station, (_, biases) in trimble.items()}


def _identify(biases, values):
    return identify(channel_clock_biases_from_arrays(values, 30.0, biases.satellites),
                    HodDetector(interval_s=30.0, window=10, pfa=1e-3))


@pytest.mark.slow
def test_a_step_that_ends_is_raised_at_onset_and_cleared_after_it_ends_never_before_on_each_real_channel(real):
    cases = 0
    for station in STATIONS:
        biases = real[station]
        full = [j for j in range(len(biases.satellites)) if np.isfinite(biases.bias_s[:, j]).all()]
        for j in full:
            x = inject(biases.bias_s, Anomaly("step", start_s=ONSET_S, offset_s=STEP_S, channel=j), 30.0)
            x = inject(x, Anomaly("step", start_s=END_S, offset_s=-STEP_S, channel=j), 30.0)  # the fault ends
            res = _identify(biases, x)
            faulty, events = latch_channels(res)
            name = biases.satellites[j]
            assert [(e.channel, e.kind) for e in events] == [(name, "raise"), (name, "clear")], (station, events)
            raised, cleared = (res.t_s[e.epoch] for e in events)
            assert raised == ONSET_S
            # cleared once the channel has been back for a window (10 epochs) after the end, within two
            assert END_S + 10 * 30.0 <= cleared <= END_S + 20 * 30.0
            assert "back to" in events[1].reason
            on = res.t_s[faulty[:, j]]
            assert on.min() == ONSET_S and on.max() < cleared
            assert not faulty[:, [k for k in range(faulty.shape[1]) if k != j]].any()
            cases += 1
    assert cases == 10


@pytest.mark.slow
def test_a_step_that_stays_is_never_cleared_although_its_statistic_goes_quiet(real):
    biases = real["30400920"]
    j = biases.satellites.index("G11")
    res = _identify(biases, inject(biases.bias_s, Anomaly("step", start_s=ONSET_S, offset_s=STEP_S, channel=j), 30.0))
    faulty, events = latch_channels(res)
    assert [(e.channel, e.kind) for e in events] == [("G11", "raise")]
    k0 = int(np.flatnonzero(res.t_s == ONSET_S)[0])
    assert faulty[k0:, j].all() and not faulty[:k0, j].any()
    # the statistic alone would have cleared it: quiet for more than a window before the end of the record
    assert not res.results[j].alarm[k0 + 12 :].any()


def test_the_latch_neither_raises_nor_clears_on_an_untested_epoch():
    det = HodDetector(interval_s=1.0, window=3, h0=1e-20, hm2=0.0, sigma_rho_m=0.3).fit()
    latch = ChannelLatch(det)
    for k in range(6):
        assert latch.step(k, 0.0, tested=True, alarm=False) is None
    assert latch.step(6, 1e-8, tested=True, alarm=True, named=True).startswith("raise")
    for k in range(7, 20):
        assert latch.step(k, 1e-8, tested=k % 2 == 0, alarm=False) is None  # offset kept: never back
    assert latch.faulty
    events = [latch.step(k, 0.0, tested=True, alarm=False) for k in range(20, 30)]
    assert latch.step(30, 0.0, tested=False, alarm=False) is None
    assert [e.split(":")[0] for e in events if e] == ["clear"] and not latch.faulty


@pytest.mark.slow
def test_a_step_ramp_or_drag_that_lasts_is_never_cleared_on_any_real_channel(real):
    # the faults of docs/integrity/trimble_injections.md (to the end of the record): a channel raised stays raised
    faults = {"step": dict(offset_s=30e-9), "ramp": dict(rate_s_per_s=100e-9 / 600.0),
              "drag": dict(accel_s_per_s2=1.0 / 299_792_458.0 / 30.0**2)}
    raised = 0
    for station in STATIONS:
        biases = real[station]
        full = [j for j in range(len(biases.satellites)) if np.isfinite(biases.bias_s[:, j]).all()]
        for kind, size in faults.items():
            for j in full:
                x = inject(biases.bias_s, Anomaly(kind, start_s=ONSET_S, channel=j, **size), 30.0)
                faulty, events = latch_channels(_identify(biases, x))
                name = biases.satellites[j]
                assert not [e for e in events if e.kind == "clear"], (station, kind, name, events)
                assert all(res_t >= ONSET_S for res_t in (ONSET_S + 30.0 * (e.epoch - 60) for e in events))
                raised += any(e.channel == name for e in events)
    assert raised >= 28  # of 30 cases: named in all but the ramps the margin of a 40-epoch training misses
