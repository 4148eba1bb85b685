"""Scenario files: the shipped ones validate, and mistakes are named by key and file."""

from pathlib import Path

import pytest

from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.stability import STATISTICS
from chronofuse.analysis.stability.taus import SPACINGS
from chronofuse.experiments.scenario import DEFAULT_SCENARIO, ScenarioError, load_scenario, parse_scenario
from chronofuse.models.oscillator_presets import PRESETS
from chronofuse.models.environment import ENVIRONMENTS

REPO = Path(__file__).resolve().parents[2]


def test_the_built_in_default_is_an_ocxo_and_three_urban_canyon_receivers_for_a_day():
    scn = load_scenario()
    assert (scn.oscillator.preset, scn.receivers.scenario, scn.receivers.count) == ("ocxo", "urban-canyon", 3)
    assert scn.duration_s == 86_400


def test_the_shipped_default_file_equals_the_built_in_default():
    assert load_scenario(REPO / "scenarios/default.toml") == load_scenario(DEFAULT_SCENARIO)


@pytest.mark.parametrize("path", sorted((REPO / "scenarios").glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_scenario_validates(path):
    assert load_scenario(path).name


def test_an_unknown_key_names_itself_the_file_and_a_close_match():
    with pytest.raises(ScenarioError, match=r"my.toml: duration_ms: unknown key \(did you mean 'duration_s'\?\)"):
        parse_scenario("duration_ms = 5000\n", "my.toml")


def test_an_unknown_key_in_a_section_is_named_with_its_section():
    with pytest.raises(ScenarioError, match=r"receivers.scenaro: unknown key"):
        parse_scenario('[receivers]\nscenaro = "open-sky"\n', "my.toml")


def test_a_value_of_the_wrong_unit_or_range_names_the_key():
    with pytest.raises(ScenarioError, match=r"my.toml: rate_hz: .*greater than 0"):
        parse_scenario("rate_hz = -1\n", "my.toml")
    with pytest.raises(ScenarioError, match=r"duration_s: .*got '1 day'"):
        parse_scenario('duration_s = "1 day"\n', "my.toml")
    with pytest.raises(ScenarioError, match=r"my.toml: rate_hz: .*less than or equal to 1"):
        parse_scenario("rate_hz = 2\n", "my.toml")
    with pytest.raises(ScenarioError, match=r"my.toml: rate_hz: .*whole seconds"):
        parse_scenario("rate_hz = 0.3\n", "my.toml")
    with pytest.raises(ScenarioError, match=r"receivers.scenario"):
        parse_scenario('[receivers]\nscenario = "moon"\n', "my.toml")


def test_broken_toml_and_missing_files_are_named():
    with pytest.raises(ScenarioError, match="my.toml: not valid TOML"):
        parse_scenario("duration_s = \n", "my.toml")
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario("does/not/exist.toml")


# Each key that selects from a registry, the registry, and how a value is written in TOML.
REGISTRY_KEYS = [
    ("oscillator", "preset", sorted(PRESETS), '"{}"'),
    ("receivers", "scenario", sorted(ENVIRONMENTS), '"{}"'),
    ("analysis", "deviations", sorted(STATISTICS), '["{}"]'),
    ("analysis", "mask", sorted(MASKS), '"{}"'),
    ("analysis", "taus", [s for s in SPACINGS if s != "all"], '"{}"'),
]


@pytest.mark.parametrize("section, key, names, form", REGISTRY_KEYS, ids=[f"{s}.{k}" for s, k, *_ in REGISTRY_KEYS])
def test_every_name_in_a_registry_is_accepted_and_any_other_is_refused_naming_the_key(section, key, names, form):
    for name in names:
        scn = parse_scenario(f"[{section}]\n{key} = {form.format(name)}\n", "my.toml")
        value = getattr(getattr(scn, section), key)
        assert value == ([name] if isinstance(value, list) else name)
    with pytest.raises(ScenarioError, match=rf"my.toml: {section}.{key}"):
        parse_scenario(f"[{section}]\n{key} = {form.format('no-such-name')}\n", "my.toml")


def test_the_total_deviations_and_theo1_missing_before_are_accepted():
    scn = parse_scenario('[analysis]\ndeviations = ["mtotdev", "htotdev", "ttotdev", "theo1"]\n', "my.toml")
    assert scn.analysis.deviations == ["mtotdev", "htotdev", "ttotdev", "theo1"]
