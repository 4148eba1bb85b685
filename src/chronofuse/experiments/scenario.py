"""Scenario files: TOML, validated by pydantic, with units in every key name.

A wrong key, a wrong type or a value out of range raises :class:`ScenarioError` naming the key and the
file, e.g. ``scenarios/x.toml: oscillator.duration: unknown key (known: preset, h0, ...)``.

The names a key accepts come from the registries they select from, so a statistic, mask, preset or
receiver environment added there is accepted here at once: ``oscillator.preset`` from
:data:`~chronofuse.models.oscillator_presets.PRESETS`, ``receivers.scenario`` from
:data:`~chronofuse.models.environment.ENVIRONMENTS`, ``analysis.deviations`` from
:data:`~chronofuse.analysis.stability.STATISTICS`, ``analysis.mask`` from
:data:`~chronofuse.analysis.masks.MASKS` and ``analysis.taus`` from
:data:`~chronofuse.analysis.stability.taus.SPACINGS` (less ``"all"``: one tau per sample is too many for a
report).
"""

from __future__ import annotations

import difflib
import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.stability import STATISTICS
from chronofuse.analysis.stability.taus import SPACINGS
from chronofuse.models.oscillator_presets import PRESETS
from chronofuse.experiments.gnssdo import CONTROLLERS, DEFAULT_CONTROLLER
from chronofuse.models.environment import ENVIRONMENTS
from chronofuse.sync.registry import ALGORITHM_NAMES, NEEDS_NETWORK
from chronofuse.validation import InputDataError

DEFAULT_SCENARIO = Path(__file__).resolve().parent / "default.toml"


# Literal types built from the registries (Literal[("a", "b")] is Literal["a", "b"]).
PresetName = Literal[tuple(PRESETS)]
EnvironmentName = Literal[tuple(ENVIRONMENTS)]
StatisticName = Literal[tuple(STATISTICS)]
MaskName = Literal[tuple(MASKS)]
SpacingName = Literal[tuple(s for s in SPACINGS if s != "all")]
ControllerName = Literal[tuple(CONTROLLERS)]
#: Followers run an algorithm that needs no trained network (the paper's chain with its BP or LSTM does).
SyncName = Literal[tuple(a for a in ALGORITHM_NAMES if a not in NEEDS_NETWORK)]


class ScenarioError(InputDataError):
    """A scenario file that does not validate; names the file and the key."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class OscillatorSection(_Strict):
    """The free-running oscillator: a preset, optionally with h-coefficient and drift overrides."""

    preset: PresetName = "ocxo"
    h2: float | None = Field(None, ge=0)
    h1: float | None = Field(None, ge=0)
    h0: float | None = Field(None, ge=0)
    hm1: float | None = Field(None, ge=0)
    hm2: float | None = Field(None, ge=0)
    drift_per_s: float | None = None


class ReceiversSection(_Strict):
    """The GNSS timing receivers: scenario name and how many, with independent errors."""

    scenario: EnvironmentName = "urban-canyon"
    count: int = Field(3, ge=1, le=64)


class DisciplineSection(_Strict):
    """The GNSS-disciplined oscillator: its controller and a GNSS outage (holdover) during the run."""

    enabled: bool = True
    controller: ControllerName = DEFAULT_CONTROLLER
    #: Start of the GNSS outage (s); default: the middle of the run.
    outage_start_s: float | None = Field(None, ge=0)
    #: Its length (s); default: one hour, or a quarter of a run shorter than four hours. 0: no outage.
    outage_s: float | None = Field(None, ge=0)


class SwarmSection(_Strict):
    """Followers that keep the disciplined leader's time over two-way radio links."""

    followers: int = Field(3, ge=0, le=16)
    algorithm: SyncName = "doppler-kf"
    topology: Literal["tree", "consensus"] = "tree"


class AnalysisSection(_Strict):
    """What the report computes."""

    deviations: list[StatisticName] = ["oadev", "tdev", "mtie"]
    taus: SpacingName = "decade"
    mask: MaskName | None = "prtc-a"


class Scenario(_Strict):
    """A whole run: duration, sample rate, seed, and the sections above."""

    name: str = "default"
    description: str = ""
    duration_s: float = Field(86_400.0, gt=0, le=10 * 86_400)
    rate_hz: float = Field(1.0, gt=0, le=1.0)
    seed: int = Field(20_261_124, ge=0)
    oscillator: OscillatorSection = OscillatorSection()
    receivers: ReceiversSection = ReceiversSection()
    analysis: AnalysisSection = AnalysisSection()
    discipline: DisciplineSection = DisciplineSection()
    swarm: SwarmSection = SwarmSection()

    @field_validator("rate_hz")
    @classmethod
    def _whole_second_period(cls, rate_hz: float) -> float:
        # The receivers emit one 1PPS per second: the sample period must be whole seconds.
        period_s = 1.0 / rate_hz
        if abs(period_s - round(period_s)) > 1e-9 * period_s:
            raise ValueError(f"must be 1 / (whole seconds), e.g. 1, 0.5, 0.1; got a period of {period_s:g} s")
        return rate_hz


def _known_keys(model: type[BaseModel], loc: tuple) -> list[str]:
    for part in loc[:-1]:
        field = model.model_fields.get(str(part))
        if field is None or not isinstance(field.annotation, type) or not issubclass(field.annotation, BaseModel):
            return []
        model = field.annotation
    return list(model.model_fields)


def _describe(exc: ValidationError, source: str) -> ScenarioError:
    err = exc.errors()[0]
    key = ".".join(str(p) for p in err["loc"])
    if err["type"] == "extra_forbidden":
        known = _known_keys(Scenario, err["loc"])
        hint = difflib.get_close_matches(str(err["loc"][-1]), known, n=1)
        msg = f"{key}: unknown key" + (f" (did you mean {hint[0]!r}?)" if hint else "") + f"; known keys: {known}"
    else:
        msg = f"{key}: {err['msg']} (got {err.get('input')!r})"
    return ScenarioError(msg, source)


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Parse and validate scenario TOML text."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"not valid TOML: {exc}", source) from exc
    try:
        return Scenario.model_validate(raw)
    except ValidationError as exc:
        raise _describe(exc, source) from exc


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Load a scenario file; ``None`` gives the built-in default scenario."""
    path = Path(path) if path is not None else DEFAULT_SCENARIO
    if not path.is_file():
        raise ScenarioError("no such scenario file", str(path))
    return parse_scenario(path.read_text(encoding="utf-8"), str(path))
