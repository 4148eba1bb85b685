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

from chronofuse.analysis.stability.engine import (  # noqa: F401 (this module is the family's registry module)
    STATISTIC_REGISTRY,
    Statistic,
    StatisticConfig,
    statistic_entry,
    statistic_spec,
)

__all__ = ["STATISTIC_REGISTRY", "Statistic", "StatisticConfig", "statistic_entry", "statistic_spec"]
