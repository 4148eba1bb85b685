"""The receiver's own status: its fix flags and its time accuracy estimate rule epochs out."""

import struct

import numpy as np

from chronofuse.timescale import NS_PER_WEEK
import pytest

from chronofuse.integrity.modes import detect_file
from chronofuse.integrity.receiver_status import DEFAULT_MAX_TIME_ACC_S, NO_FIX, status_reasons

MODEL = dict(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0, window=5)


def _frames(data: bytes):
    """``(offset, class, id, payload)`` of every UBX frame in a capture, by the frame layout (u-blox interface
    description: sync 0xB5 0x62, class, id, little-endian length, payload, two checksum bytes)."""
    i = 0
    while (i := data.find(b"\xb5\x62", i)) >= 0 and i + 6 <= len(data):
        n = int.from_bytes(data[i + 4 : i + 6], "little")
        yield i, data[i + 2], data[i + 3], data[i + 6 : i + 6 + n]
        i += 8 + n


@pytest.fixture(scope="module")
def gr701w(real_data):
    return (real_data / "receivers/gpsd/navisys-gr701w.log").read_bytes()


def test_no_fix_takes_precedence_and_a_time_accuracy_over_the_limit_rules_an_epoch_out():
    ok = np.array([True, True, False, True])
    tacc = np.array([50e-9, 150e-9, 150e-9, np.nan])
    reasons = status_reasons(ok, tacc, 100e-9, 4)
    assert list(reasons) == ["", "receiver status: time accuracy over 100 ns", NO_FIX, ""]
    assert list(status_reasons(None, tacc, None, 4)) == ["", "", "", ""]


def test_without_its_fix_flags_the_coasting_gr701w_is_caught_by_its_own_time_accuracy(gr701w, tmp_path):
    # the same capture with its NAV-SOL frames (the fix flags) taken out: only NAV-CLOCK's tAcc is left to
    # tell that the receiver is coasting; it grows from 41 ns at the loss of fix (29 s) to 172 ns
    kept = bytearray(gr701w)
    for offset, cls, mid, payload in reversed(list(_frames(gr701w))):
        if (cls, mid) == (0x01, 0x06):
            del kept[offset : offset + 8 + len(payload)]
    path = tmp_path / "gr701w-no-nav-sol.log"
    path.write_bytes(bytes(kept))
    # the reference: tAcc (U4, ns, payload bytes 12-15) and iTOW (U4, ms) of each NAV-CLOCK frame, decoded here
    clock = [struct.unpack_from("<IiiI", p) for _, c, m, p in _frames(gr701w) if (c, m) == (0x01, 0x22)]
    over = [itow for itow, _, _, tacc in clock if tacc > DEFAULT_MAX_TIME_ACC_S * 1e9]
    assert len(over) == 10 and over == list(range(over[0], over[-1] + 1000, 1000))
    # NAV-SOL (iTOW U4 at 0, flags X1 at 11, bit 0 gpsFixOk): the coasting epochs, and their tAcc from 41 to 172 ns
    no_fix = {struct.unpack_from("<I", p)[0] for _, c, m, p in _frames(gr701w) if (c, m) == (0x01, 0x06) and not p[11] & 1}
    coasting = [tacc for itow, _, _, tacc in clock if itow in no_fix]
    assert len(coasting) == 29 and (coasting[0], max(coasting)) == (41, 172) and set(over) <= no_fix
    doc = detect_file(path, **MODEL)
    assert doc["n_no_fix"] == 0 and doc["n_time_accuracy_over"] == 10
    spans = [u for u in doc["unavailable"] if u["reason"].startswith("receiver status: time accuracy over 100 ns")]
    # times are GPS ns (the record keeps the receiver's full epoch); their time of week is the frames' iTOW
    assert doc["time_scale"] == "gps"
    assert [(u["from_ns"] % NS_PER_WEEK, u["to_ns"] % NS_PER_WEEK) for u in spans] == [(over[0] * 10**6, over[-1] * 10**6)]
    assert not [a for a in doc["alarms"] if over[0] * 10**6 <= a["t_ns"] % NS_PER_WEEK <= over[-1] * 10**6]
    # with the limit off (None), those epochs are tested as healthy: the coasting clock looks clean
    off = detect_file(path, **MODEL, max_time_acc_s=None)
    # (the 10 epochs, and the 2 after them where the difference chain restarted)
    assert off["n_time_accuracy_over"] == 0 and off["n_tested"] == doc["n_tested"] + 10 + 2
    assert not [a for a in off["alarms"] if over[0] * 10**6 <= a["t_ns"] % NS_PER_WEEK <= over[-1] * 10**6]


def test_with_its_fix_flags_the_gr701w_is_unavailable_for_no_fix_whatever_the_accuracy_limit(real_data):
    path = real_data / "receivers/gpsd/navisys-gr701w.log"
    strict = detect_file(path, **MODEL, max_time_acc_s=40e-9)
    default = detect_file(path, **MODEL)
    assert default["n_no_fix"] == strict["n_no_fix"] == 29 and default["n_time_accuracy_over"] == 0
    # healthy epochs after the fix returned report 44-63 ns: a 40 ns limit rules them out too
    assert strict["n_time_accuracy_over"] > 0 and strict["n_tested"] < default["n_tested"]


def test_the_command_default_accuracy_limit_is_the_library_default():
    from chronofuse.cli import detect as detect_cli

    assert detect_cli._DEFAULT_MAX_TACC_NS * 1e-9 == pytest.approx(DEFAULT_MAX_TIME_ACC_S)
