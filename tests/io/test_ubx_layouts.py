"""The compiled layouts (io/ubx_layouts.py) against pyubx2 itself: every field of every frame of the
compiled message types in every UBX recording of tests/data, equal to what pyubx2 decodes."""

from __future__ import annotations

import pytest
from pyubx2 import UBXReader

from chronofuse.io.frames import scan_bytes
from chronofuse.io.ubx_layouts import FIXED_TYPES, decode_fixed

from .conftest import receivers_dir


def _frames():
    out = []
    for path in sorted(receivers_dir().rglob("*")):
        if not path.is_file() or path.suffix in (".chk", ".md") or path.name == "COPYING":
            continue
        try:
            frames, _ = scan_bytes(path.read_bytes())
        except Exception:  # noqa: BLE001 - a file the framer does not take is not a UBX recording
            continue
        out += [f for f in frames if f.kind == "ubx" and f.name in FIXED_TYPES]
    return out


FRAMES = _frames()


def test_the_recordings_hold_every_compiled_message_type():
    assert {f.name for f in FRAMES} >= {"NAV-PVT", "NAV-SOL", "NAV-STATUS", "NAV-TIMEGPS", "NAV-TIMEUTC", "NAV-DOP",
                                         "NAV-CLOCK", "TIM-TP"}


@pytest.mark.parametrize("name", FIXED_TYPES)
def test_every_field_equals_pyubx2s_on_every_frame(name):
    frames = [f for f in FRAMES if f.name == name]
    compared = 0
    for frame in frames:
        ours = decode_fixed(frame.name, frame.raw)
        if ours is None:  # shorter than the layout: pyubx2 decodes it, as before
            continue
        theirs = UBXReader.parse(frame.raw, validate=0)
        for attr, value in vars(ours).items():
            assert getattr(theirs, attr) == value, (frame.name, frame.offset, attr)
        compared += 1
    if name != "NAV-EOE" and name != "NAV-TIMELS":
        assert compared > 0 and compared >= len(frames) // 2, (name, compared, len(frames))
