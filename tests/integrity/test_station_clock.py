"""The compiled step of a code's clocks (:func:`~chronofuse.integrity.station_clock.clock_step_kernel`) equals
its numpy twin bit for bit: arcs that start and end, exclusions, ties, codes of one to many channels."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from chronofuse.integrity.station_clock import CodeClock, leave_one_out_medians


def _run(bias, excluded, fast):
    clock = CodeClock(bias.shape[0], fast=fast)
    out = []
    for k in range(bias.shape[1]):
        e = clock.step(bias[:, k], excluded[:, k])
        clock.commit(e)
        out.append((e.residual_s, e.restarted, e.common_s, e.arc_start))
    return out


def _same(a, b):
    for (r1, s1, c1, a1), (r2, s2, c2, a2) in zip(a, b):
        assert np.array_equal(r1, r2, equal_nan=True) and np.array_equal(s1, s2) and np.array_equal(a1, a2)
        assert (np.isnan(c1) and np.isnan(c2)) or c1 == c2


@settings(max_examples=40, deadline=None)
@given(channels=st.integers(1, 14), epochs=st.integers(2, 60), seed=st.integers(0, 2**31 - 1),
       coarse=st.booleans())
def test_the_compiled_step_equals_the_numpy_twin(channels, epochs, seed, coarse):
    rng = np.random.default_rng(seed)
    clock = np.cumsum(rng.normal(0, 1e-9, epochs))
    bias = clock[None, :] + rng.normal(0, 3e-9, (channels, epochs))
    if coarse:  # ties in every median
        bias = np.round(bias * 1e9) / 1e9
    bias[rng.random((channels, epochs)) < 0.2] = np.nan  # arcs that break and start again
    excluded = rng.random((channels, epochs)) < 0.1
    _same(_run(bias, excluded, True), _run(bias, excluded, False))


def test_on_a_real_station_the_compiled_and_numpy_clocks_agree_and_the_common_clock_is_removed(igs_stations):
    from chronofuse.io.station_channels import station_channels

    st_ = igs_stations["NYA1"]
    ch = station_channels(st_.observations().select(slice(0, 240)), st_.navigation(), st_.reference_arp_m)
    groups = [i for i, (_, code) in enumerate(ch.channels) if code == ch.channels[0][1]]
    bias = np.ascontiguousarray(ch.bias_s[groups])
    excluded = np.zeros(bias.shape, bool)
    excluded[0, 100:] = True  # a satellite named faulty at epoch 100
    fast, slow = _run(bias, excluded, True), _run(bias, excluded, False)
    _same(fast, slow)
    # the oracle of the arithmetic: an epoch's leave-one-out median read off one sort equals the median of the
    # others taken directly
    values, member = bias[:, 50], np.isfinite(bias[:, 50])
    meds, _ = leave_one_out_medians(values, member)
    for i in np.flatnonzero(member):
        others = values[member & (np.arange(values.size) != i)]
        assert meds[i] == np.median(others)
