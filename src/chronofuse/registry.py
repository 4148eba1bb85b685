"""One registry per family: a name maps to a member (a class, or a preset object) and a pydantic config.

Every family the program lets a user choose from by name — stability statistics, clock-bias detectors,
servos, sync algorithms, receiver environments, ITU masks, oscillator presets — is one :class:`Registry`
defined beside its members, in the layer that owns them (:data:`FAMILIES` says where). This module is the
mechanism, written once.

A member is an :class:`Entry`: its ``target`` (a class, or a preset object such as an
:class:`~chronofuse.models.oscillator.OscillatorModel`), its ``config`` (a subclass of :class:`Config`, a
pydantic model whose every field carries its unit, in the field's name or at the end of its description:
``steer_s``, ``"window length (epochs)"``) and a one-line ``summary``. :meth:`Registry.create` validates the
settings against the config (an unknown setting or a bad value is refused, naming the setting) and builds
the member:

* a class target is called with the config's fields as keyword arguments, plus the family's ``shared``
  keywords taken from ``context`` (what the caller knows and every member of the family accepts: a
  servo's ``interval_s`` and ``dac``, a detector's ``interval_s``);
* an object target (a preset) is copied with the settings given (``dataclasses.replace``);
* an entry with a ``build(config, context)`` function is built by it (a member that needs more of the
  caller's context, e.g. the Kalman servos take the oscillator's h-coefficients from it).

Plugins. A package adds members through package entry points, one group per family, named
``chronofuse.<family>`` (:func:`group`); the entry point's name is the member's name and its object an
:class:`Entry`. In the plugin's ``pyproject.toml``::

    [project.entry-points."chronofuse.servos"]
    my-servo = "my_package.servo:ENTRY"

Entry points are listed when the names are first asked for and loaded when a name is first used, so an
installed plugin costs nothing until it is chosen; a plugin that fails to load raises :class:`PluginError`
naming its entry point and distribution. A plugin may not take a built-in's name: the built-in is kept and a
warning names the plugin. :meth:`Registry.refresh` forgets what was read (after installing a package into
a running interpreter).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from chronofuse.validation import ChronofuseError, InputDataError

__all__ = ["Config", "Entry", "Registry", "PluginError", "FAMILIES", "group"]

#: The families and the module that holds each one's registry.
FAMILIES = {
    "statistics": "chronofuse.analysis.stability.statistic_registry",
    "detectors": "chronofuse.integrity.registry",
    "servos": "chronofuse.discipline.registry",
    "sync": "chronofuse.sync.registry",
    "environments": "chronofuse.models.environment",
    "masks": "chronofuse.analysis.mask_registry",
    "oscillators": "chronofuse.models.oscillator_presets",
}


def group(family: str) -> str:
    """The entry-point group of ``family``: ``"chronofuse.<family>"``."""
    return f"chronofuse.{family}"


class PluginError(ChronofuseError, RuntimeError):
    """A plugin's entry point could not be loaded or is not an :class:`Entry` (a fault of the plugin)."""


class Config(BaseModel):
    """Base of every member's config: frozen, unknown settings refused, any Python type allowed as a field.

    Give every field a ``description`` that ends with its unit in parentheses (``"(s)"``, ``"(1/s)"``,
    ``"(epochs)"``, ``"(dimensionless)"``) unless the field's name already ends in one (``_s``, ``_hz``,
    ``_m``); ``tests/test_registry.py`` checks every registered config.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)

    def settings(self) -> dict[str, Any]:
        """The fields as keyword arguments (objects kept as they are, not turned into dicts)."""
        return {name: getattr(self, name) for name in type(self).model_fields}


@dataclass(frozen=True)
class Entry:
    """One member of a family (module docstring): ``target``, ``config``, ``summary`` and an optional ``build``."""

    target: Any
    config: type[Config]
    summary: str = ""
    build: Callable[[Config, Mapping[str, Any]], Any] | None = None

    def __post_init__(self):
        if not (isinstance(self.config, type) and issubclass(self.config, BaseModel)):
            raise TypeError(f"config == {self.config!r}, must be a pydantic model class (a chronofuse.registry.Config)")


class Registry:
    """The members of one family by name (module docstring).

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`; the entry-point group is ``chronofuse.<family>``.
    shared : tuple of str
        Keywords every member's class accepts, passed from ``context`` by :meth:`create`.
    builtins : callable, optional
        Returns ``{name: Entry}`` of members defined elsewhere (a table such as the stability engine's),
        read when the registry is first used, so that members added to that table later are included.
    """

    def __init__(self, family: str, *, shared: tuple[str, ...] = (),
                 builtins: Callable[[], Mapping[str, Entry]] | None = None):
        self.family = family
        self.shared = tuple(shared)
        self._builtins_source = builtins
        self._entries: dict[str, Entry] = {}
        self._plugin_points: dict[str, metadata.EntryPoint] | None = None
        self._plugins: dict[str, Entry] = {}

    def __repr__(self) -> str:
        return f"Registry({self.family!r}, {len(self.names())} members)"

    @property
    def group(self) -> str:
        return group(self.family)

    # -- members ---------------------------------------------------------------------------------------

    def add(self, name: str, entry: Entry) -> Entry:
        """Register the built-in member ``name`` (refused if the name is taken); returns ``entry``."""
        if not isinstance(entry, Entry):
            raise TypeError(f"entry == {entry!r}, must be a chronofuse.registry.Entry")
        if name in self._builtin():
            raise ValueError(f"{self.family}: {name!r} is registered already")
        self._entries[name] = entry
        return entry

    def _builtin(self) -> dict[str, Entry]:
        if self._builtins_source is not None:
            table = dict(self._builtins_source())
            self._builtins_source = None
            for name, entry in table.items():
                self._entries.setdefault(name, entry)
        return self._entries

    def _points(self) -> dict[str, metadata.EntryPoint]:
        if self._plugin_points is None:
            points = {}
            for point in metadata.entry_points(group=self.group):
                if point.name in self._builtin():
                    warnings.warn(f"plugin entry point {point.name!r} = {point.value!r} of {_dist(point)} names a "
                                  f"built-in {self.family} member; the built-in is kept", stacklevel=3)
                    continue
                points.setdefault(point.name, point)
            self._plugin_points = points
        return self._plugin_points

    def refresh(self) -> None:
        """Forget the plugins read so far (the next lookup lists the entry points again)."""
        self._plugin_points = None
        self._plugins = {}

    def names(self) -> tuple[str, ...]:
        """Every member's name: the built-ins in registration order, then the plugins' in sorted order."""
        return tuple(self._builtin()) + tuple(sorted(self._points()))

    def builtin_names(self) -> tuple[str, ...]:
        """The built-in members' names only."""
        return tuple(self._builtin())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (name in self._builtin() or name in self._points())

    def entry(self, name: str) -> Entry:
        """The :class:`Entry` called ``name``; a plugin's is loaded on first use."""
        builtin = self._builtin()
        if name in builtin:
            return builtin[name]
        if name in self._plugins:
            return self._plugins[name]
        point = self._points().get(name) if isinstance(name, str) else None
        if point is None:
            raise InputDataError(f"{self.family} member {name!r} is unknown; known: {', '.join(self.names())}")
        try:
            entry = point.load()
        except Exception as exc:
            raise PluginError(f"plugin {self.family} member {name!r} ({point.value} of {_dist(point)}) failed to "
                              f"load: {type(exc).__name__}: {exc}") from exc
        if not isinstance(entry, Entry):
            raise PluginError(f"plugin {self.family} member {name!r} ({point.value} of {_dist(point)}) is "
                              f"{type(entry).__name__}, must be a chronofuse.registry.Entry")
        self._plugins[name] = entry
        return entry

    # -- configs and members ---------------------------------------------------------------------------

    def config(self, name: str, **settings) -> Config:
        """The validated config of ``name`` with ``settings``; a bad or unknown setting is refused by name."""
        entry = self.entry(name)
        try:
            return entry.config(**settings)
        except ValidationError as exc:
            raise InputDataError(_explain(self.family, name, entry.config, exc)) from None

    def create(self, name: str, *, context: Mapping[str, Any] | None = None, **settings):
        """Build the member ``name`` with ``settings`` (its config's fields) and the caller's ``context``."""
        entry = self.entry(name)
        config = self.config(name, **settings)
        context = dict(context or {})
        if entry.build is not None:
            return entry.build(config, context)
        target = entry.target
        if isinstance(target, type):
            shared = {key: context[key] for key in self.shared if key in context}
            return target(**config.settings(), **shared)
        return dataclasses.replace(target, **{key: getattr(config, key) for key in config.model_fields_set})

    def describe(self, name: str) -> dict:
        """``{"name", "summary", "settings": {field: {"default", "description"}}}`` of member ``name``."""
        entry = self.entry(name)
        fields = {key: {"default": info.default, "description": info.description or ""}
                  for key, info in entry.config.model_fields.items()}
        return {"name": name, "summary": entry.summary, "settings": fields}


def _dist(point: metadata.EntryPoint) -> str:
    dist = getattr(point, "dist", None)
    return f"distribution {dist.name} {dist.version}" if dist is not None else "an unknown distribution"


def _explain(family: str, name: str, config: type[BaseModel], exc: ValidationError) -> str:
    """One line per problem: ``servo 'kf': steer_s == -1.0, must be greater than 0``."""
    parts = []
    for err in exc.errors():
        where = ".".join(str(p) for p in err["loc"]) or "settings"
        if err["type"] == "extra_forbidden":
            parts.append(f"{where} is not a setting of {family} member {name!r} (its settings: "
                         f"{', '.join(config.model_fields) or 'none'})")
        else:
            parts.append(f"{family} member {name!r}: {where} == {err.get('input')!r}, {err['msg'].lower()}")
    return "; ".join(parts)
