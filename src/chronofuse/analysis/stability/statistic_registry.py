"""The stability statistics by name: :data:`STATISTIC_REGISTRY`, the family's registry (:mod:`chronofuse.registry`).

The statistics themselves stay where they are, one :class:`~chronofuse.analysis.stability.registry.StatisticSpec`
each in the engine's table :data:`~chronofuse.analysis.stability.registry.STATISTICS` (a member added
there is in this registry too); this module puts them behind the one registry mechanism, so that a
plugin can add a statistic and :func:`~chronofuse.analysis.stability.engine.compute` runs it by name.

``STATISTIC_REGISTRY.create(name, ci=..., bias_correction=...)`` gives a :class:`Statistic`, the
statistic with its settings bound: ``stat(x_s, rate_hz, tau_s) -> Deviation``. A plugin's entry point (group
``chronofuse.statistics``) is :func:`statistic_entry` of its ``StatisticSpec`` (kernel, range, gap policy,
EDF family, bias correction: what the engine needs to compute it).
"""

from __future__ import annotations

from pydantic import Field

from chronofuse.analysis.stability.registry import STATISTICS, StatisticSpec
from chronofuse.registry import Config, Entry, Registry

__all__ = ["STATISTIC_REGISTRY", "Statistic", "StatisticConfig", "statistic_entry", "statistic_spec"]


class StatisticConfig(Config):
    """What :func:`~chronofuse.analysis.stability.engine.compute` lets a caller choose for any statistic."""

    ci: float = Field(0.683, gt=0.0, lt=1.0, description="confidence of the interval (dimensionless)")
    bias_correction: bool = Field(True, description="apply the statistic's bias correction, as Stable32 does (bool)")


class Statistic:
    """One statistic with its settings: ``stat(x_s, rate_hz, tau_s)`` is ``compute(name, x_s, rate_hz, tau_s,
    ci=..., bias_correction=...)`` (a :class:`~chronofuse.analysis.stability.result.Deviation`)."""

    def __init__(self, name: str, spec: StatisticSpec, *, ci: float = 0.683, bias_correction: bool = True):
        self.name = name
        self.spec = spec
        self.ci = ci
        self.bias_correction = bias_correction

    def __call__(self, x_s, rate_hz: float, tau_s):
        from chronofuse.analysis.stability.engine import compute

        return compute(self.name, x_s, rate_hz, tau_s, ci=self.ci, bias_correction=self.bias_correction)

    def __repr__(self) -> str:
        return f"Statistic({self.name!r}, ci={self.ci}, bias_correction={self.bias_correction})"


def _build(config: StatisticConfig, context) -> Statistic:
    spec = context["spec"]
    return Statistic(spec.name, spec, **config.settings())


def statistic_entry(spec: StatisticSpec, summary: str = "") -> Entry:
    """The registry entry of ``spec`` (what a plugin's entry point names)."""
    if not isinstance(spec, StatisticSpec):
        raise TypeError(f"spec == {spec!r}, must be a StatisticSpec")
    return Entry(spec, StatisticConfig, summary, lambda config, context: _build(config, {"spec": spec}))


STATISTIC_REGISTRY = Registry("statistics", builtins=lambda: {name: statistic_entry(spec)
                                                              for name, spec in STATISTICS.items()})


def statistic_spec(name: str) -> StatisticSpec:
    """The :class:`StatisticSpec` called ``name``: the engine's table first, then the plugins."""
    if name in STATISTICS:
        return STATISTICS[name]
    try:
        entry = STATISTIC_REGISTRY.entry(name)
    except ValueError:
        raise ValueError(f"statistic == {name!r}, must be one of {sorted(STATISTIC_REGISTRY.names())}") from None
    if not isinstance(entry.target, StatisticSpec):
        raise TypeError(f"statistic {name!r}: its entry's target is {entry.target!r}, must be a StatisticSpec")
    return entry.target
