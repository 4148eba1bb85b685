"""NAV-SAT's used-satellite count read by the frame layout equals pyubx2's decoding of every NAV-SAT frame
in the real captures, and a frame shorter than its satellite count says is refused, never misread."""

from __future__ import annotations

import pytest
from pyubx2 import UBXReader

from chronofuse.io.frames import FrameScanner
from chronofuse.io.ubx_epochs import nav_sat_used


def _nav_sat_frames(path) -> list[bytes]:
    scanner = FrameScanner()
    frames = scanner.feed(path.read_bytes()) + scanner.close()
    return [f.raw for f in frames if f.kind == "ubx" and f.name == "NAV-SAT"]


@pytest.mark.parametrize("name", ["gpsd/u-blox-m8t-time.log", "gpsd/ublox-zed-f9p-hp.log", "gpsd/ublox-glo.log",
                                  "gpsd/ublox-x20p.log", "gpsd/navisys-gr8013.log"])
def test_the_used_satellite_count_is_pyubx2s_svused_sum_on_every_frame(receivers, name):
    frames = _nav_sat_frames(receivers / name)
    assert frames, name
    for raw in frames:
        msg = UBXReader.parse(raw)
        expected = sum(1 for k in range(1, msg.numSvs + 1) if getattr(msg, f"svUsed_{k:02d}"))
        assert nav_sat_used(raw) == expected


def test_a_nav_sat_frame_shorter_than_its_count_is_refused(receivers):
    raw = _nav_sat_frames(receivers / "gpsd" / "u-blox-m8t-time.log")[0]
    assert raw[11] > 0
    for cut in (raw[:-14], raw[:12]):
        with pytest.raises(ValueError, match="shorter than its satellite count"):
            nav_sat_used(cut)
