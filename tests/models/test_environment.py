"""One environment registry: one name is one site in the timing and the pseudorange simulations, with one
receiver clock, and that clock is the free-running receiver oscillator real stations show."""

import dataclasses
import math
import warnings

import numpy as np
import pytest

from chronofuse.gnss import simulate as gnss_simulate
from chronofuse.integrity.clock_events import repair_clock_steering
from chronofuse.io.rinex_clock import read_station_clocks, station_clock_bias
from chronofuse.models.environment import (
    ENVIRONMENT_REGISTRY,
    ENVIRONMENTS,
    ReceiverEnvironment,
    SignalEnvironment,
    receiver_environment,
    signal_environments,
)
from chronofuse.models.receiver import simulate_receivers
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.validation import InputDataError

from _helpers import receivers_dir

IGS_CLOCKS = receivers_dir() / "rinex" / "rtklib" / "igs15904.clk.gz"
TAU_S = 300.0


def _second_difference_rms_s(h0: float, hm2: float, tau_s: float) -> float:
    """rms of ``x(k) - 2 x(k-1) + x(k-2)`` at spacing ``tau_s`` for white FM ``h0`` and random-walk FM ``hm2``:
    ``sqrt(2 q1 tau + 2/3 q2 tau^3)``, ``q1 = h0 / 2``, ``q2 = 2 pi^2 hm2`` (the r(0) of the clock-bias model)."""
    q1, q2 = h0 / 2.0, 2.0 * math.pi**2 * hm2
    return math.sqrt(2.0 * q1 * tau_s + 2.0 / 3.0 * q2 * tau_s**3)


def _free_running_station_rms_s() -> np.ndarray:
    """Per station of the IGS product with an internal (free-running) oscillator, the rms second difference
    of its repaired clock at 300 s. Internal oscillators show as 1 ms clock resets (the receiver steers its
    clock to within a millisecond) or as a frequency offset above 1e-7 (a maser- or caesium-driven station
    is within 1e-10)."""
    clocks = read_station_clocks(IGS_CLOCKS)
    out = []
    for name in clocks.stations:
        try:
            data = station_clock_bias(clocks, name)  # an EpochRecord on the station's grid
        except InputDataError:  # a station with one epoch: no interval, no second difference
            continue
        if data.interval_ns != round(TAU_S * 1e9):
            continue
        repaired = repair_clock_steering(data.column("clock_bias_s"))
        x = repaired.repaired_s
        d2 = np.diff(x, 2)
        d2 = d2[np.isfinite(d2)]
        if d2.size < 5:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            frequency = np.nanmedian(np.abs(np.diff(x))) / TAU_S
        if repaired.event_epochs.size or frequency > 1e-7:
            out.append(math.sqrt(np.mean(d2**2)))
    return np.array(out)


def test_the_receiver_clock_model_is_what_free_running_receiver_clocks_of_an_igs_product_show():
    rms = _free_running_station_rms_s()
    assert rms.size == 10  # URUM, LHAZ, UNBJ, TIXJ, MAL2, METS, OHI2, UNSA, ZWE2, MANA
    rng = np.random.default_rng(20240601)
    medians = np.median(rng.choice(rms, (20_000, rms.size)), axis=1)
    low, high = np.percentile(medians, [2.5, 97.5])  # 95 % bootstrap interval of the stations' median
    model = ReceiverModel()
    ours = _second_difference_rms_s(model.clock_h0, model.clock_hm2, TAU_S)
    assert low <= ours <= high
    # the other value one registry used to carry is outside: 6e-22 is far noisier than these clocks
    assert _second_difference_rms_s(model.clock_h0, 6e-22, TAU_S) > 2.0 * high


def test_every_site_with_a_pseudorange_view_has_one_receiver_clock_in_both_views():
    for name, env in ENVIRONMENTS.items():
        if env.signal is None:
            continue
        assert (env.signal.clock_h0, env.signal.clock_hm2) == (env.model.clock_h0, env.model.clock_hm2), name
        assert env.signal.name == name
    assert gnss_simulate.ENVIRONMENTS == signal_environments()
    assert set(gnss_simulate.ENVIRONMENTS) == {"open-sky", "urban-canyon", "paper-canyon", "jamming", "tunnel"}


def test_a_signal_view_given_with_another_clock_takes_the_receiver_models_clock():
    noisy = SignalEnvironment("x", clock_hm2=6e-22)
    env = ReceiverEnvironment("mine", ReceiverModel(clock_hm2=2e-23), signal=noisy)
    assert env.signal.clock_hm2 == 2e-23 and env.signal.name == "mine"
    moved = dataclasses.replace(env, model=ReceiverModel(clock_hm2=3e-23))
    assert moved.signal.clock_hm2 == 3e-23


def test_a_tunnel_takes_the_fix_away_in_the_timing_view_and_jamming_in_the_pseudorange_view():
    tunnel = receiver_environment("tunnel")
    truth = simulate_receivers(tunnel, 1000, 2, seed=3)
    inside = ((truth.t_s >= 300.0) & (truth.t_s < 360.0)) | ((truth.t_s >= 900.0) & (truth.t_s < 960.0))
    assert np.array_equal(tunnel.jammed(truth.t_s), inside)
    assert not truth.epochs.has_fix[..., inside].any()
    assert truth.epochs.has_fix[..., ~inside].mean() > 0.99
    jam = gnss_simulate.ENVIRONMENTS["jamming"]
    assert jam.outages_s == ((600.0, 1200.0),)


def test_the_spoofed_site_has_no_pseudorange_view_and_says_why():
    with pytest.raises(ValueError, match="no spoofer"):
        receiver_environment("spoofing").pseudorange_view()
    with pytest.raises(ValueError, match="no pseudorange view"):
        ReceiverEnvironment("bare", ReceiverModel()).pseudorange_view()


def test_the_registry_replaces_the_events_given_and_refuses_a_setting_it_does_not_have():
    fast = ENVIRONMENT_REGISTRY.create("spoofing", spoof_rate_s_per_s=2e-8)
    assert fast.spoof_rate_s_per_s == 2e-8 and fast.spoof_start_s == 600.0 and fast.model is ENVIRONMENTS["spoofing"].model
    with pytest.raises(ValueError, match="white_sigma_s is not a setting"):
        ENVIRONMENT_REGISTRY.create("open-sky", white_sigma_s=1e-9)
    with pytest.raises(ValueError, match="environment"):
        receiver_environment("desert")
