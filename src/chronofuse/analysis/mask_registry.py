"""The ITU-T masks by clock class: :data:`MASK_REGISTRY`, the family's registry (:mod:`chronofuse.registry`).

The masks stay where they are, as data in :data:`chronofuse.analysis.masks.MASKS` (each segment naming
its table; a mask added there is in this registry too). A plugin adds a clock class with an entry point in
the group ``chronofuse.masks`` whose object is :func:`mask_entry` of its
:class:`~chronofuse.analysis.masks.ClockMasks`. A mask has no setting: ``MASK_REGISTRY.create(name)`` is
the :class:`ClockMasks` itself, and :func:`clock_masks` looks one up by name, plugins included.
"""

from __future__ import annotations

from chronofuse.analysis.masks import MASKS, ClockMasks
from chronofuse.registry import Config, Entry, Registry

__all__ = ["MASK_REGISTRY", "MaskConfig", "mask_entry", "clock_masks"]


class MaskConfig(Config):
    """A mask is a published table: nothing to set."""


def mask_entry(masks: ClockMasks) -> Entry:
    """The registry entry of one clock class's masks."""
    if not isinstance(masks, ClockMasks):
        raise TypeError(f"masks == {masks!r}, must be a ClockMasks")
    return Entry(masks, MaskConfig, f"MTIE, TDEV and max |TE| limits of {masks.name} ({masks.reference})",
                 lambda config, context: masks)


MASK_REGISTRY = Registry("masks", builtins=lambda: {name: mask_entry(m) for name, m in MASKS.items()})


def clock_masks(name: str) -> ClockMasks:
    """The :class:`ClockMasks` of clock class ``name`` (the built-in table first, then plugins)."""
    if name in MASKS:
        return MASKS[name]
    return MASK_REGISTRY.create(name)
