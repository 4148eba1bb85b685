"""The u-blox messages the epoch builder uses, decoded from pyubx2's own layout tables in one
``struct.unpack`` each.

pyubx2 describes every message as data (``UBX_PAYLOADS_GET["NAV-CLOCK"] == {"iTOW": "U004", "clkB":
"I004", ...}``, bitfields as ``("X001", {"validDate": "U001", ...})``, scaled fields as ``("U002",
0.01)``). Its reader walks that table field by field, setting attributes one at a time: about 0.1-0.3 ms
per message, most of the monitor's time at 200 receivers x 10 Hz. :func:`compile_layout` turns the same
table, once, into a ``struct`` format, the bitfields' shifts and masks and the scales;
:func:`decode_fixed` then gives an object with pyubx2's attribute names and values (scaled values rounded
as pyubx2 rounds them). A test compares every field with pyubx2 on every such frame of the recordings in
``tests/data``.

Only messages without repeating groups are compiled (:data:`FIXED_TYPES`); a payload shorter than its
layout (an older protocol version) or of another message goes to pyubx2, as before.
"""

from __future__ import annotations

import struct
from types import SimpleNamespace

from pyubx2 import UBX_PAYLOADS_GET

__all__ = ["FIXED_TYPES", "compile_layout", "decode_fixed"]

#: The messages decoded here (the rest of :data:`chronofuse.io.ubx_epochs.UBX_TYPES` through pyubx2).
FIXED_TYPES = ("NAV-PVT", "NAV-SOL", "NAV-STATUS", "NAV-TIMEGPS", "NAV-TIMEUTC", "NAV-TIMELS", "NAV-DOP", "NAV-CLOCK",
               "TIM-TP", "NAV-EOE")
_SCALROUND = 12  # pyubx2.ubxtypes_core.SCALROUND: the digits its scaled values are rounded to
_CODES = {("U", 1): "B", ("U", 2): "H", ("U", 4): "I", ("U", 8): "Q", ("I", 1): "b", ("I", 2): "h", ("I", 4): "i",
          ("I", 8): "q", ("X", 1): "B", ("X", 2): "H", ("X", 4): "I", ("R", 4): "f", ("R", 8): "d"}


def _code(kind: str) -> tuple[str, bool]:
    """The struct code of a pyubx2 type ('U004' -> 'I'); (``'3s'``, False) for odd sizes kept as bytes."""
    letter, size = kind[0], int(kind[1:])
    code = _CODES.get((letter, size))
    return (code, True) if code is not None else (f"{size}s", False)


def compile_layout(name: str) -> tuple[struct.Struct, list]:
    """``(Struct, fields)`` for message ``name``; each field is ``(attribute, scale or None, bits)`` where
    ``bits`` is None or a list of ``(sub-attribute, shift, mask)`` of a bitfield."""
    layout = UBX_PAYLOADS_GET[name]
    codes, fields = ["<"], []
    for attr, kind in layout.items():
        if isinstance(kind, tuple) and isinstance(kind[1], dict):  # a bitfield
            code, numeric = _code(kind[0])
            if not numeric:
                raise ValueError(f"{name}.{attr}: bitfield of {kind[0]} is not compiled")
            shift, bits = 0, []
            for sub, width in kind[1].items():
                n = int(width[1:])
                bits.append((sub, shift, (1 << n) - 1))
                shift += n
            codes.append(code)
            fields.append((attr, None, bits))
        elif isinstance(kind, tuple):  # (type, scale)
            code, numeric = _code(kind[0])
            codes.append(code)
            fields.append((attr, float(kind[1]), None))
        elif isinstance(kind, str) and kind[0] in "UIXR" and kind[1:].isdigit():
            code, numeric = _code(kind)
            codes.append(code)
            fields.append((attr, None, None) if numeric else (attr, "bytes", None))
        else:
            raise ValueError(f"{name}.{attr}: {kind!r} (a repeating group or a string) is not compiled")
    return struct.Struct("".join(codes)), fields


_COMPILED = {name: compile_layout(name) for name in FIXED_TYPES}


def decode_fixed(name: str, raw: bytes):
    """The message in the whole frame ``raw`` (checksum already verified) as an object with pyubx2's
    attribute names, or None when it is not compiled here or its payload is shorter than the layout."""
    compiled = _COMPILED.get(name)
    if compiled is None:
        return None
    layout, fields = compiled
    if len(raw) - 8 < layout.size:
        return None
    values = layout.unpack_from(raw, 6)
    out = {}
    for (attr, scale, bits), value in zip(fields, values):
        if bits is not None:
            for sub, shift, mask in bits:
                if not sub.startswith("reserved"):  # pyubx2 sets no reserved attributes
                    out[sub] = (value >> shift) & mask
        elif attr.startswith("reserved"):
            continue
        elif scale is None:
            out[attr] = value
        elif scale == "bytes":
            out[attr] = int.from_bytes(value, "little")
        else:
            out[attr] = round(value * scale, _SCALROUND)
    return SimpleNamespace(**out)
