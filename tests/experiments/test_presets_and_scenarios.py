"""Every oscillator preset and every shipped scenario file disciplines; overrides are honoured or refused by name."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.discipline.dac import Dac
from chronofuse.experiments.gnssdo import (INITIAL_FREQUENCY_MAX, SCENARIOS, GnssdoSetup, _free_phase, initial_frequency_max,
                                           simulate_gnssdo)
from chronofuse.experiments.main_chain import _follower_velocities_m_s
from chronofuse.experiments.main_job import run_scenario
from chronofuse.experiments.scenario import ScenarioError, load_scenario, parse_scenario
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator_presets import PRESETS, preset
from chronofuse.seeding import root_seed
from chronofuse.validation import InputError

SCENARIOS_DIR = Path(__file__).resolve().parents[2] / "scenarios"


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_starts_inside_its_efc_range_with_room_for_the_runs_aging(name):
    osc = preset(name)
    lo, hi = Dac.for_oscillator(osc).frequency_range
    duration = 2 * 86_400
    fmax = initial_frequency_max(osc, duration)
    assert 0 < fmax <= INITIAL_FREQUENCY_MAX
    assert fmax + abs(osc.drift_per_s) * duration < 0.75 * min(-lo, hi)
    # The drawn offsets: the free phase's mean slope (aging and noise aside) stays inside that bound.
    free, noise = _free_phase(osc, 4000, 64, root_seed(3))
    slope = (free[:, -1] - noise[:, -1] - (free[:, 0] - noise[:, 0])) / 3999
    assert np.all(np.abs(slope) <= initial_frequency_max(osc, 4000) * (1 + 1e-9))


def test_an_oscillator_whose_aging_outruns_its_efc_is_refused_naming_it():
    import dataclasses

    osc = dataclasses.replace(preset("rb"), drift_per_s=1e-13)
    with pytest.raises(ValueError, match="oscillator 'rb': its aging"):
        initial_frequency_max(osc, 86_400.0)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_is_steered_off_its_rails_in_open_sky(name):
    sim = simulate_gnssdo(GnssdoSetup(oscillator=name, duration_s=7200, trials=4, seed=2, design="datasheet"))
    run = sim["run"]
    # The acquisition's first seconds may pull to a rail (the frequency estimate still settling), never later.
    assert not run.loop.near_rail[:, 600:].any()
    assert (run.states.state == 2).any(axis=1).all()


def test_gnssdo_refuses_an_unknown_oscillator_by_name():
    # The library names its field (the command line writes it as --oscillator: tests/cli/test_gnssdo_cli.py).
    with pytest.raises(InputError, match=r"oscillator == 'maser', must be one of \['csac', 'ocxo', 'rb', 'tcxo'\]"):
        GnssdoSetup(oscillator="maser")


def test_a_scenario_files_oscillator_overrides_reach_the_disciplined_oscillator(tmp_path):
    text = ('name = "o"\nduration_s = 7200\nseed = 4\n[oscillator]\npreset = "ocxo"\nhm2 = 1e-26\n'
            'drift_per_s = 3e-15\n[receivers]\nscenario = "open-sky"\ncount = 2\n[swarm]\nfollowers = 0\n')
    report = run_scenario(parse_scenario(text, "o.toml"), tmp_path)
    d = report.summary["discipline"]
    assert d["oscillator"] == "ocxo"
    # The report's free run and the disciplined oscillator are one realisation of the overridden model.
    from chronofuse.experiments.main_job import _oscillator_model

    scn = parse_scenario(text, "o.toml")
    model = _oscillator_model(scn)
    sim = simulate_gnssdo(GnssdoSetup(scenario="open-sky", receivers=2, duration_s=7200, seed=4, oscillator_model=model,
                                      outage_start_s=3600, outage_s=1800, design="datasheet"))
    csv = np.loadtxt(tmp_path / "timeseries.csv", delimiter=",", skiprows=1, usecols=1)
    assert np.allclose(csv * 1e-9, sim["noise_phase_s"][0, :csv.size], rtol=1e-9, atol=1e-18)
    assert model.h.hm2 == 1e-26 and model.drift_per_s == 3e-15
    assert sim["oscillator"].h.hm2 == 1e-26


def test_a_scenario_at_another_rate_than_1_hz_is_refused_naming_rate_hz_before_writing(tmp_path):
    text = 'duration_s = 7200\nrate_hz = 0.5\n[receivers]\nscenario = "open-sky"\n'
    out = tmp_path / "out"
    with pytest.raises(ScenarioError, match="rate_hz: 0.5 Hz with discipline enabled"):
        run_scenario(parse_scenario(text, "r.toml"), out)
    assert not out.exists()


def test_followers_stay_inside_the_links_reply_slot_over_the_longest_run_a_scenario_allows():
    link = LinkModel()
    for duration in (7200.0, 86_400.0, 172_800.0, 10 * 86_400.0):
        v = _follower_velocities_m_s(3, duration)
        far = max(20e3 + 30e3 * i + abs(v[i]) * duration for i in range(3))
        assert far / 299_792_458.0 < 0.9 * link.reply_delay_s


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_receiver_environment_is_a_gnssdo_scenario(name):
    sim = simulate_gnssdo(GnssdoSetup(scenario=name, duration_s=3600, seed=1, design="datasheet"))
    assert sim["run"].phase_s.shape == (1, 3600) and sim["environment"].name == name


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(SCENARIOS_DIR.glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_scenario_file_runs_to_a_report(path, tmp_path):
    # The file as shipped parses; it then runs for 6 h (the two-day Rb run alone took 93 s of the suite), an
    # outage it has moved to 2 h in: every section of it but the length reaches the report.
    scenario = load_scenario(path)
    assert scenario.duration_s >= 21_600
    text = re.sub(r"(?m)^duration_s\s*=.*$", "duration_s = 21600", path.read_text())
    text = re.sub(r"(?m)^outage_start_s\s*=.*$", "outage_start_s = 7200", text)
    short = tmp_path / path.name
    short.write_text(text)
    result = CliRunner().invoke(app, ["run", str(short), "--out", str(tmp_path / "out"), "--json"])
    assert result.exit_code == 0, result.output[-2000:]
    summary = json.loads(result.stdout)
    d = summary["discipline"]
    assert d["state_seconds"]["locked"] > 0
    assert d["locked_over_threshold_seconds"] == 0
    assert d["dac_rail_alarm_seconds"] < 10  # at most the acquisition's first pull
