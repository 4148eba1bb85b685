"""Temperature through the tempco in holdover: a diurnal swing makes the disciplined OCXO's holdover worse by
about the integral the tempco predicts, and a compensation table recovers most of it.

Oracle: ``c int_0^h (T(t0 + s) - T(t0)) ds`` (:func:`chronofuse.models.temperature.holdover_temperature_error_s`).
The three runs share the oscillator's noise and the receivers (paired), so their difference is the
temperature's part: the loop's lag on the rising temperature adds to it (measured 8.5 % at 4 h).
"""

import numpy as np
import pytest

from chronofuse.discipline.dac import Dac
from chronofuse.discipline.holdover import holdover_error
from chronofuse.discipline.loop import close_loop
from chronofuse.experiments.gnssdo import _free_phase, make_controller, scenario_environment
from chronofuse.models.oscillator import OscillatorModel, PowerLaw, simulate_oscillator
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.models.temperature import (CompensationTable, compensated_phase_s, diurnal_profile,
                                           holdover_temperature_error_s, step_profile, temperature_phase_s)
from chronofuse.seeding import child_seed, root_seed
from chronofuse.validation import InputError

LOCKED = 86_400
HORIZONS = np.array([3600.0, 4 * 3600.0])


@pytest.fixture(scope="module")
def runs():
    osc = preset("ocxo")
    c = osc.temp_coeff_per_K
    steps = LOCKED + int(HORIZONS.max()) + 1
    trials = 8
    env = scenario_environment("open-sky", float(LOCKED))
    root = root_seed(5)
    free, _ = _free_phase(osc, steps, trials, root)
    rx = simulate_receivers(env, LOCKED, 2, child_seed(root, 1), trials=trials)
    ref = np.full((trials, steps), np.nan)
    ref[:, :LOCKED] = np.nanmean(rx.pps_error_s + rx.epochs.qerr_s, axis=1)
    servo = make_controller("kalman", osc, env, 2, Dac.for_oscillator(osc))
    temp = diurnal_profile(steps, amplitude_K=5.0, phase_rad=-2 * np.pi * LOCKED / 86_400)  # rising at t0
    table = CompensationTable.from_tempco(0.9 * c, osc.temp_ref_K, 280.0, 320.0)  # a tempco measured 10 % low
    out = {}
    for name, add in (("constant", 0.0), ("diurnal", temperature_phase_s(temp, c, osc.temp_ref_K)),
                      ("compensated", compensated_phase_s(temp, c, osc.temp_ref_K, table))):
        out[name] = holdover_error(close_loop(servo, free + add, ref).phase_s, LOCKED, HORIZONS)
    out["theory"] = holdover_temperature_error_s(temp, LOCKED, HORIZONS, c)
    out["theory_compensated"] = holdover_temperature_error_s(temp, LOCKED, HORIZONS, c, table)
    return out


def test_a_diurnal_swing_worsens_holdover_by_about_the_tempco_integral(runs):
    extra = (runs["diurnal"] - runs["constant"]).mean(axis=0)
    assert runs["theory"][-1] > 200e-9  # 5 K through the OCXO preset's 7e-12/K: a quarter microsecond in 4 h
    assert 1.0 <= extra[-1] / runs["theory"][-1] <= 1.15
    rms = {k: np.sqrt(np.mean(runs[k][:, -1] ** 2)) for k in ("constant", "diurnal", "compensated")}
    assert rms["diurnal"] > 1.2 * rms["constant"]


def test_the_compensation_table_recovers_most_of_it(runs):
    left = (runs["compensated"] - runs["constant"]).mean(axis=0)
    extra = (runs["diurnal"] - runs["constant"]).mean(axis=0)
    assert abs(left[-1]) < 0.15 * abs(extra[-1])  # a table 10 % off leaves about 10 %
    assert runs["theory_compensated"][-1] == pytest.approx(0.1 * runs["theory"][-1], rel=1e-6)


def test_the_temperature_phase_is_what_the_oscillator_simulation_adds():
    model = OscillatorModel("t", 10e6, PowerLaw(), 0.0, 3e-11, 0.0, 1, 1.0, "test")
    temp = step_profile(1000, base_K=300.0, step_K=2.0, at_s=400.0)
    x = simulate_oscillator(model, 1000.0, 1.0, 1, temperature_K=temp).x_s[0]
    assert np.allclose(x, temperature_phase_s(temp, 3e-11, model.temp_ref_K), rtol=1e-12, atol=1e-21)


def test_a_bad_table_is_refused():
    with pytest.raises(InputError, match="increase"):
        CompensationTable((300.0, 290.0), (0.0, 1e-12))
    with pytest.raises(InputError, match="two rows"):
        CompensationTable((300.0,), (0.0,))


def test_the_holdover_study_shows_the_temperature_and_its_compensation():
    """The study's option: the diurnal swing raises ours at 4 h, a table 10 % off brings it back near the
    constant-temperature figure, and each row carries the tempco integral."""
    from chronofuse.experiments.gnssdo_holdover import holdover_study

    kw = dict(horizons_s=(4 * 3600.0,), trials=4, design="datasheet", seed=5)
    const = holdover_study(86_400, **kw)["rows"][0]
    warm = holdover_study(86_400, temperature_amplitude_K=5.0, **kw)
    comp = holdover_study(86_400, temperature_amplitude_K=5.0, compensation_error=0.1, **kw)["rows"][0]
    row = warm["rows"][0]
    assert "temperature_theory_ns" not in const and row["temperature_theory_ns"] == pytest.approx(245.5, rel=1e-3)
    assert row["ours_ns"] > const["ours_ns"] + 50
    assert abs(comp["ours_ns"] - const["ours_ns"]) < 0.2 * (row["ours_ns"] - const["ours_ns"])
    assert comp["temperature_theory_ns"] == pytest.approx(-24.55, rel=1e-3)
