"""Sources: a real loopback TCP server that drops the connection and comes back, a pseudo-terminal
serial device that disappears and returns, a gzip file, gpsd JSON, and several sources at once. In each
the reader keeps going and the epochs decoded equal the batch reader's on the same bytes."""

from __future__ import annotations

import gzip
import os
import socket
import threading
import time

import numpy as np
import pytest

from chronofuse.io.arrival import REORDER_EPOCHS
from chronofuse.io.inspect import read_bytes, read_capture
from chronofuse.io.sources import Backoff, FileSource, GpsdSource, SerialSource, SourceGroup, TcpSource, parse_source
from chronofuse.io.sources_decode import GpsdJsonDecoder, StreamDecoder

from .conftest import receivers_dir

CAPTURE = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"


def _collect(group: SourceGroup, until, timeout_s: float = 20.0) -> list:
    events, deadline = [], time.monotonic() + timeout_s
    while time.monotonic() < deadline and not until(events):
        event = group.get(0.2)
        if event is not None:
            events.append(event)
    return events


def _epochs(events, decoder) -> list[dict]:
    out = []
    for e in events:
        if e.kind == "data":
            out += decoder.feed(e.data)
    return out + decoder.close()


def test_backoff_doubles_to_its_cap_and_resets():
    b = Backoff(0.1, 0.5)
    assert [b.next() for _ in range(5)] == [0.1, 0.2, 0.4, 0.5, 0.5]
    b.reset()
    assert b.next() == 0.1


def test_a_tcp_source_survives_the_server_dropping_and_coming_back():
    data = CAPTURE.read_bytes()
    half = len(data) // 2
    server = socket.socket()
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    sent = threading.Event()

    def serve():
        for part in (data[:half], data[half:]):
            conn, _ = server.accept()
            conn.sendall(part)
            time.sleep(0.2)
            conn.close()  # the receiver's network port drops
        sent.set()

    threading.Thread(target=serve, daemon=True).start()
    source = TcpSource("127.0.0.1", port, backoff=Backoff(0.05, 0.2))
    with SourceGroup([source]) as group:
        events = _collect(group, lambda ev: sent.is_set() and sum(e.kind == "down" for e in ev) >= 2)
    server.close()
    kinds = [e.kind for e in events if e.kind != "data"]
    assert kinds[:4] == ["up", "down", "up", "down"]
    received = b"".join(e.data for e in events if e.kind == "data")
    assert received == data
    live = _epochs(events, StreamDecoder())
    assert [e["gps_ns"] for e in live] == read_capture(CAPTURE).rows["gps_ns"].tolist()


def test_a_serial_device_that_disappears_and_returns_is_read_again(tmp_path):
    data = CAPTURE.read_bytes()
    half = len(data) // 2
    link = tmp_path / "ttyGNSS"  # like /dev/serial/by-id/...: the name stays, the device behind it changes

    def plug():
        master, slave = os.openpty()
        link.symlink_to(os.ttyname(slave))
        return master, slave

    def unplug(master, slave):
        link.unlink()
        os.close(slave)
        os.close(master)

    master, slave = plug()
    source = SerialSource(str(link), 115200, backoff=Backoff(0.05, 0.2))
    with SourceGroup([source]) as group:
        assert _collect(group, lambda ev: any(e.kind == "up" for e in ev))
        os.write(master, data[:half])
        first = _collect(group, lambda ev: sum(len(e.data) for e in ev if e.kind == "data") >= half)
        unplug(master, slave)
        gone = _collect(group, lambda ev: any(e.kind == "down" for e in ev))
        master, slave = plug()
        back = _collect(group, lambda ev: any(e.kind == "up" for e in ev))
        os.write(master, data[half:])
        rest = _collect(group, lambda ev: sum(len(e.data) for e in ev if e.kind == "data") >= len(data) - half)
    unplug(master, slave)
    events = first + gone + back + rest
    assert b"".join(e.data for e in events if e.kind == "data") == data
    assert any(e.kind == "down" for e in gone) and any(e.kind == "up" for e in back)
    live = _epochs(events, StreamDecoder())
    assert [e["gps_ns"] for e in live] == read_capture(CAPTURE).rows["gps_ns"].tolist()


def test_several_sources_at_once_each_deliver_all_their_bytes(tmp_path):
    packed = tmp_path / "m8t.log"  # gzip content without a .gz name: told by its magic bytes
    packed.write_bytes(gzip.compress(CAPTURE.read_bytes()))
    other = receivers_dir() / "gpsd" / "ublox-zed-f9t-ubx_nmea_l5.log"
    sources = [FileSource(packed, name="a"), FileSource(other, name="b", chunk=1000)]
    with SourceGroup(sources) as group:
        events = _collect(group, lambda ev: sum(e.kind == "end" for e in ev) == 2)
    for name, path in (("a", CAPTURE), ("b", other)):
        assert b"".join(e.data for e in events if e.source == name and e.kind == "data") == path.read_bytes()


def test_gpsd_json_from_a_gpsd_server_becomes_epochs_with_gpsd_time_mode_and_dops():
    chk = (receivers_dir() / "gpsd" / "u-blox-m8t-time.log.chk").read_bytes()
    reports = b"".join(line + b"\n" for line in chk.splitlines() if line.startswith(b"{"))
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    asked = []

    def serve():
        conn, _ = server.accept()
        asked.append(conn.recv(100))
        conn.sendall(b'{"class":"VERSION","release":"3.25"}\n' + reports)
        conn.close()

    threading.Thread(target=serve, daemon=True).start()
    with SourceGroup([GpsdSource("127.0.0.1", port, backoff=Backoff(5.0))]) as group:
        events = _collect(group, lambda ev: any(e.kind == "down" for e in ev))
    server.close()
    assert asked[0].startswith(b"?WATCH=")
    epochs = _epochs(events, GpsdJsonDecoder())
    ours = read_capture(receivers_dir() / "gpsd" / "u-blox-m8t-time.log")
    common = set(e["gps_ns"] for e in epochs) & set(ours.rows["gps_ns"].tolist())
    assert len(common) >= 149
    assert {e["fix_mode"] for e in epochs} == {3}


def test_the_live_decoder_gives_the_batch_readers_epochs_whatever_the_split(receivers):
    # one protocol per capture (mixed ones: the next test)
    for name in ("ublox-neo-m8t.log", "bundg_zeus_9.log", "u-blox-m8t-time.log", "navisys-gr701w.log"):
        data = (receivers / "gpsd" / name).read_bytes()
        batch = read_bytes([data]).rows
        decoder, live = StreamDecoder(), []
        for k in range(0, len(data), 777):
            live += decoder.feed(data[k:k + 777])
        live += decoder.close()
        for field in batch:
            got = np.array([e[field] for e in live])
            np.testing.assert_array_equal(got, batch[field], err_msg=f"{name}: {field}")


@pytest.mark.parametrize("spec,kind", [("serial:/dev/ttyUSB0@115200", SerialSource), ("tcp:10.0.0.2:5000", TcpSource),
                                       ("gpsd:localhost", GpsdSource), ("file:/x.ubx", FileSource),
                                       ("rec.nmea", FileSource)])
def test_source_specs_name_their_kind(spec, kind):
    assert isinstance(parse_source(spec), kind)


MIXED = ("ublox-zed-f9p_hpg1.11.log", "ublox-zed-f9r.log", "ublox-zed-f9t-ubx_nmea_l5.log", "ublox8-uniqid-monhw.log")


def _live(decoder: StreamDecoder, data: bytes, rng) -> tuple[list[dict], list[dict]]:
    """Feed ``data`` in random chunks of 1 to 3000 bytes: (epochs from feed, epochs from close)."""
    fed, k = [], 0
    while k < len(data):
        n = int(rng.integers(1, 3000))
        fed += decoder.feed(data[k:k + n])
        k += n
    return fed, decoder.close()


@pytest.mark.parametrize("name", MIXED)
def test_a_receiver_sending_nmea_and_ubx_on_one_port_gives_the_file_readers_merged_epochs(receivers, name):
    data = (receivers / "gpsd" / name).read_bytes()
    batch = read_capture(receivers / "gpsd" / name)
    assert set(batch.protocols) == {"nmea", "ubx"}
    for seed in range(3):
        fed, closed = _live(StreamDecoder(), data, np.random.default_rng(seed))
        live = fed + closed
        for field in batch.rows:
            got = np.array([e[field] for e in live])
            np.testing.assert_array_equal(got, batch.rows[field], err_msg=f"{name} seed {seed}: {field}")
        # released as the stream goes, not only at its end (at most the epoch in progress, one behind and the
        # epochs the reorder buffer holds, chronofuse.io.arrival)
        assert len(closed) <= 3 + REORDER_EPOCHS, (name, len(closed))


def test_when_ubx_falls_silent_the_nmea_epochs_keep_coming_after_the_wait(receivers):
    from chronofuse.io.frames import FrameScanner

    data = (receivers / "gpsd" / "ublox-zed-f9p_hpg1.11.log").read_bytes()
    scanner = FrameScanner()
    frames = scanner.feed(data) + scanner.close()
    half = frames[len(frames) // 2].offset
    # the receiver stops its UBX output half-way: only NMEA (and RTCM) frames after that
    tail = b"".join(f.raw for f in frames if f.offset >= half and f.kind != "ubx")
    stream = data[:half] + tail
    decoder = StreamDecoder(max_wait_s=3.0)
    fed, closed = _live(decoder, stream, np.random.default_rng(7))
    batch = read_bytes([stream]).rows
    assert len(fed) + len(closed) == batch["gps_ns"].size
    # the last epochs wait for UBX at most max_wait_s of NMEA time, then NMEA alone carries the stream
    assert batch["gps_ns"][-1] - fed[-1]["gps_ns"] <= (4 + REORDER_EPOCHS) * 10**9 and len(closed) <= 5 + REORDER_EPOCHS
    late = [e for e in fed if e["gps_ns"] > batch["gps_ns"][-1] - 100 * 10**9]
    assert late and all(np.isnan(e["clock_bias_s"]) for e in late)


UBX_ONLY = ("gpsd/navisys-gr701w.log", "gpsd/navisys-gr8013.log", "gpsd/u-blox-m8t-time.log", "gpsd/ublox-8-time.log",
            "gpsd/ublox-aek-4t.log", "gpsd/ublox-f9p-rtcm.log", "gpsd/ublox-glo.log", "gpsd/ublox-lea-4t.log",
            "gpsd/ublox-lea-m8f.log", "gpsd/ublox-neo-f9v.log", "gpsd/ublox-neo-m8l.log", "gpsd/ublox-neo-m8n.log",
            "gpsd/ublox-neo-m8p.log", "gpsd/ublox-neo-m8t-s.log", "gpsd/ublox-neo-m8t.log", "gpsd/ublox-neo-m8u-hnr.log",
            "gpsd/ublox-neo-m8u.log", "gpsd/ublox-x20p.log", "gpsd/ublox-zed-f9p-hp.log", "gpsd/ublox-zed-f9p-rtk.log",
            "gpsd/ublox-zed-f9p-sfrbx.log", "gpsd/ublox-zed-f9t-rtcm3.log", "ubx/mon_span.ubx", "ubx/pygpsdata-MIXED.log",
            "ubx/pygpsdata-NAV-ZED-X20P.log", "ubx/pygpsdata-RXMRAWX.log", "ubx/pygpsdata_testobsnavdata.log")


@pytest.mark.parametrize("name", UBX_ONLY)
def test_the_scalar_live_path_of_a_ubx_only_stream_gives_the_batch_readers_epochs(receivers, name):
    # UBX alone takes the builder's scalar twin (pop_complete_records); the batch reader its arrays
    data = (receivers / name).read_bytes()
    batch = read_capture(receivers / name)
    assert batch.protocols == ("ubx",)
    for seed in range(2):
        decoder = StreamDecoder()
        fed, closed = _live(decoder, data, np.random.default_rng(seed))
        live = fed + closed
        for field in ("gps_ns",) + tuple(f for f in batch.rows if f in live[0]):
            got = np.array([e[field] for e in live])
            np.testing.assert_array_equal(got, batch.rows[field], err_msg=f"{name} seed {seed}: {field}")
        assert decoder.ubx_stats.pulses_without_epoch == batch.ubx.pulses_without_epoch
