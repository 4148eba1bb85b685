"""The registry mechanism, and every family built on it: a name maps to a member and a config whose every
field carries its unit; settings are validated and refused by name."""

from __future__ import annotations

import dataclasses
import importlib
import re

import pytest
from pydantic import Field

from chronofuse.analysis.mask_registry import MASK_REGISTRY, clock_masks
from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.stability.registry import STATISTICS
from chronofuse.analysis.stability.statistic_registry import STATISTIC_REGISTRY, Statistic
from chronofuse.discipline.registry import SERVOS
from chronofuse.integrity.registry import DETECTORS
from chronofuse.models.environment import ENVIRONMENT_REGISTRY, ENVIRONMENTS
from chronofuse.models.oscillator_presets import OSCILLATORS, PRESETS
from chronofuse.registry import FAMILIES, Config, Entry, Registry, group
from chronofuse.sync.registry import ALGORITHM_NAMES, SYNC
from chronofuse.validation import InputDataError

REGISTRIES = {"servos": SERVOS, "detectors": DETECTORS, "statistics": STATISTIC_REGISTRY, "masks": MASK_REGISTRY,
              "environments": ENVIRONMENT_REGISTRY, "oscillators": OSCILLATORS, "sync": SYNC}

# A unit at the end of a description, or in the field's name.
_UNIT_AT_END = re.compile(r"\(([^()]+)\)\s*$")
_UNIT_SUFFIXES = ("_s", "_hz", "_m", "_per_s", "_per_s3", "_per_K", "_per_V", "_V", "_K", "_deg", "_s_per_s",
                  "_s_per_s2")


class _Gain(Config):
    gain: float = Field(1.0, gt=0.0, description="loop gain (dimensionless)")


class _Thing:
    def __init__(self, gain, *, interval_s=1.0):
        self.gain, self.interval_s = gain, interval_s


@dataclasses.dataclass(frozen=True)
class _Preset:
    gain: float
    other: float = 3.0


def test_a_name_builds_its_class_with_its_settings_and_the_familys_shared_context():
    reg = Registry("things", shared=("interval_s",))
    reg.add("thing", Entry(_Thing, _Gain, "a thing"))
    made = reg.create("thing", context={"interval_s": 0.5, "unrelated": 1}, gain=2.0)
    assert (made.gain, made.interval_s) == (2.0, 0.5)
    assert reg.names() == ("thing",) and "thing" in reg and group("things") == "chronofuse.things"
    assert reg.describe("thing")["settings"]["gain"] == {"default": 1.0, "description": "loop gain (dimensionless)"}


def test_a_preset_object_is_copied_with_only_the_settings_given():
    reg = Registry("presets")
    base = _Preset(gain=5.0, other=7.0)
    reg.add("p", Entry(base, _Gain))
    assert reg.create("p") == base and reg.create("p", gain=2.0) == _Preset(2.0, 7.0)


def test_an_unknown_name_or_setting_or_a_bad_value_is_refused_by_name():
    reg = Registry("things")
    reg.add("thing", Entry(_Thing, _Gain))
    with pytest.raises(InputDataError, match="things member 'nope' is unknown; known: thing"):
        reg.create("nope")
    with pytest.raises(InputDataError, match=r"gian is not a setting of things member 'thing' \(its settings: gain\)"):
        reg.create("thing", gian=2.0)
    with pytest.raises(InputDataError, match="things member 'thing': gain == -1.0, input should be greater than 0"):
        reg.create("thing", gain=-1.0)
    with pytest.raises(ValueError, match="registered already"):
        reg.add("thing", Entry(_Thing, _Gain))
    with pytest.raises(TypeError, match="pydantic model class"):
        Entry(_Thing, dict)


def test_every_family_the_brief_names_has_its_registry_where_families_says():
    assert set(FAMILIES) == {"statistics", "detectors", "servos", "sync", "environments", "masks", "oscillators"}
    for family, registry in REGISTRIES.items():
        module = importlib.import_module(FAMILIES[family])
        assert registry in vars(module).values(), family
        assert registry.family == family


@pytest.mark.parametrize("family", sorted(REGISTRIES))
def test_every_setting_of_every_member_carries_its_unit(family):
    registry = REGISTRIES[family]
    for name in registry.builtin_names():
        for field, info in registry.entry(name).config.model_fields.items():
            described = info.description and _UNIT_AT_END.search(info.description)
            assert described or field.endswith(_UNIT_SUFFIXES), f"{family} {name}: {field} has no unit"


def test_the_tables_members_are_behind_their_registries_and_build_what_the_tables_hold():
    assert STATISTIC_REGISTRY.builtin_names() == tuple(STATISTICS)
    stat = STATISTIC_REGISTRY.create("oadev", ci=0.9)
    assert isinstance(stat, Statistic) and stat.ci == 0.9 and stat.spec is STATISTICS["oadev"]
    assert MASK_REGISTRY.builtin_names() == tuple(MASKS) and clock_masks("prtc-a") is MASKS["prtc-a"]
    assert OSCILLATORS.builtin_names() == tuple(PRESETS)
    assert OSCILLATORS.create("ocxo", drift_per_s=2e-15) == dataclasses.replace(PRESETS["ocxo"], drift_per_s=2e-15)
    assert ENVIRONMENT_REGISTRY.builtin_names() == tuple(ENVIRONMENTS)
    assert SERVOS.builtin_names() == ("null", "pi", "kalman", "adaptive-kalman", "gated-kalman", "huber-kalman")
    assert DETECTORS.builtin_names() == ("chi-square", "single-epoch", "cusum", "reference-clock")
    assert SYNC.builtin_names() == tuple(ALGORITHM_NAMES) and "doppler-kf" in ALGORITHM_NAMES


def test_a_statistic_from_the_registry_computes_what_compute_does():
    import numpy as np

    from chronofuse.analysis.stability import compute

    x = np.cumsum(np.random.default_rng(2).standard_normal(4096)) * 1e-9
    taus = np.array([1.0, 4.0, 16.0])
    ours = STATISTIC_REGISTRY.create("mdev", ci=0.95)(x, 1.0, taus)
    np.testing.assert_array_equal(ours.dev, compute("mdev", x, 1.0, taus, ci=0.95).dev)
    with pytest.raises(ValueError, match="statistic == 'adevv', must be one of"):
        compute("adevv", x, 1.0, taus)


def test_an_oscillator_override_the_preset_does_not_have_is_refused_by_name():
    with pytest.raises(InputDataError, match="drift is not a setting of oscillators member 'ocxo'"):
        OSCILLATORS.create("ocxo", drift=1e-15)
    with pytest.raises(InputDataError, match="dac_bits == 40"):
        OSCILLATORS.create("tcxo", dac_bits=40)
