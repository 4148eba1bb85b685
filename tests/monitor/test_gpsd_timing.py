"""gpsd as a timing source, with a real gpsd under gpsfake (Debian's packages) replaying a u-blox capture:
the monitor takes gpsd's TOFF reports as each epoch's arrival time (the system time gpsd read the time
message), and says what a gpsd source cannot give."""

from __future__ import annotations

import json
import socket
import subprocess
import threading
import time

import jsonschema

from _real_parts import MonitorProcess, tool
from chronofuse.io.sources_decode import GpsdJsonDecoder
from chronofuse.monitor.status import load_schema

from .conftest import receivers_dir

F9P = receivers_dir() / "gpsd" / "ublox-zed-f9p_hpg1.11.log"  # gpsd 3.22 sends a TOFF for each of its epochs


def _free_port() -> int:
    with socket.create_server(("127.0.0.1", 0)) as s:
        return s.getsockname()[1]


def _watch(port: int, lines: list, stop: threading.Event) -> None:
    """A second gpsd client, asking for the same reports the monitor asks for; keeps every JSON line."""
    deadline = time.monotonic() + 20
    while not stop.is_set():
        try:
            conn = socket.create_connection(("127.0.0.1", port), timeout=1)
            break
        except OSError:
            if time.monotonic() > deadline:
                return
            time.sleep(0.1)
    conn.sendall(b'?WATCH={"enable":true,"json":true,"pps":true};\n')
    conn.settimeout(0.5)
    buffer = b""
    while not stop.is_set():
        try:
            data = conn.recv(65536)
        except socket.timeout:
            continue
        except OSError:
            break
        if not data:
            break
        buffer += data
    conn.close()
    lines.extend(json.loads(line) for line in buffer.splitlines() if line.startswith(b"{"))


def test_the_gpsd_decoder_takes_toff_as_arrival_and_pps_as_the_edge():
    dec = GpsdJsonDecoder()
    second = 1_614_103_471  # 2021-02-23T18:04:31Z
    out = dec.feed(b'{"class":"TOFF","real_sec":%d,"real_nsec":0,"clock_sec":%d,"clock_nsec":120000000}\n'
                   b'{"class":"TPV","mode":3,"time":"2021-02-23T18:04:31.000Z","leapseconds":18}\n'
                   b'{"class":"PPS","real_sec":%d,"real_nsec":0,"clock_sec":%d,"clock_nsec":1500,"qErr":-2300}\n'
                   b'{"class":"TPV","mode":3,"time":"2021-02-23T18:04:32.000Z","leapseconds":18}\n'
                   % (second, second + 5, second, second + 5))
    assert len(out) == 1
    epoch = out[0]
    assert epoch["received_unix_ns"] == (second + 5) * 10**9 + 120_000_000
    assert epoch["pps_unix_ns"] == (second + 5) * 10**9 + 1_500
    assert epoch["qerr_s"] == -2.3e-9  # gpsd's PPS qErr is in picoseconds
    assert epoch["clock_bias_s"] != epoch["clock_bias_s"]  # NaN: gpsd reports no clock bias


def test_a_gpsd_source_gets_gpsds_toff_arrival_times_and_says_what_it_cannot_give(tmp_path):
    port = _free_port()
    gpsfake = subprocess.Popen([tool("gpsfake"), "-q", "-1", "-P", str(port), "-c", "0.01", str(F9P)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    seen: list = []
    stop = threading.Event()
    watcher = threading.Thread(target=_watch, args=(port, seen, stop), daemon=True)
    proc = None
    try:
        proc = MonitorProcess([f"gpsd:127.0.0.1:{port}", "--connect-timeout-s", "20", "--json-lines", "--no-table",
                               "--http", "127.0.0.1:0", "--stale-s", "60"], tmp_path)
        url = proc.url()
        watcher.start()
        deadline = time.monotonic() + 40
        while len(proc.stdout_path.read_text().splitlines()) < 12 and time.monotonic() < deadline:
            time.sleep(0.2)
        import urllib.request

        doc = json.loads(urllib.request.urlopen(url + "api/status", timeout=10).read())
    finally:
        if proc is not None:
            proc.stop()
        stop.set()
        watcher.join(5)
        gpsfake.terminate()
        gpsfake.wait(10)
    records = [json.loads(line) for line in proc.stdout_path.read_text().splitlines()]
    assert len(records) >= 12, proc.stderr()
    toff = {r["real_sec"]: r["clock_sec"] * 10**9 + r["clock_nsec"] for r in seen if r.get("class") == "TOFF"}
    assert toff, "gpsd sent no TOFF"
    matched = 0
    for r in records:
        utc_s = (r["gps_ns"] - r["leap_s"] * 10**9) // 10**9 + 315_964_800
        if utc_s in toff:
            assert r["received_unix_ns"] == toff[utc_s]  # gpsd's own receipt time of that second's message
            matched += 1
    assert matched >= 5
    jsonschema.validate(doc, load_schema())
    entry = doc["receivers"][0]
    assert entry["source"] == "gpsd"
    assert {"clock_bias_s", "clock_drift_s_per_s", "leap_pending", "qerr_s"} <= set(entry["unavailable"])
