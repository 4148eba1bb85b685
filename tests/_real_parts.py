"""Real parts the monitor's tests start (importable as ``_real_parts``): headless Chromium driven by
chromedriver (Debian's packages, through selenium), a chronyd that does not touch the system clock, a
loopback TCP "receiver" the test feeds epoch by epoch, and ``chronofuse monitor`` as a subprocess.

``make test`` installs the Debian packages; a missing one is an error here, never a skip.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage")


def tool(name: str) -> str:
    """The path of a Debian tool the test needs (``make test`` installs it); an error when missing."""
    found = shutil.which(name) or shutil.which(name, path="/usr/sbin:/usr/bin:/sbin:/bin")
    if found is None:
        raise RuntimeError(f"{name} is not installed: run `make test` (it installs chrony, gpsd, gpsd-clients, "
                           "chromium and chromium-driver), or apt-get install them")
    return found


def chromium(user_data_dir: Path):
    """A headless Chromium under chromedriver (Debian's), a fresh profile in ``user_data_dir``."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = tool("chromium")
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={user_data_dir}")
    return webdriver.Chrome(service=Service(tool("chromedriver")), options=options)


class TcpReceiver:
    """A loopback TCP server standing for a receiver's network port: the test ``send`` s its bytes;
    ``drop()`` closes the client's connection (the monitor reconnects)."""

    def __init__(self) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self._conn: socket.socket | None = None
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._accept, daemon=True)
        self._thread.start()

    @property
    def spec(self) -> str:
        return f"tcp:127.0.0.1:{self.port}"

    @property
    def name(self) -> str:
        return f"127.0.0.1:{self.port}"

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            self._conn = conn
            self._ready.set()

    def wait_client(self, timeout_s: float = 20.0) -> None:
        assert self._ready.wait(timeout_s), "the monitor never connected"

    def send(self, data: bytes) -> None:
        self.wait_client()
        self._conn.sendall(data)

    def drop(self) -> None:
        self._ready.clear()
        if self._conn is not None:
            self._conn.close()

    def close(self) -> None:
        self.drop()
        self.server.close()


class MonitorProcess:
    """``chronofuse monitor ARGS`` as a subprocess (stdout and stderr captured to files)."""

    def __init__(self, args: list[str], cwd: Path, env: dict | None = None) -> None:
        self.stdout_path = cwd / "monitor.stdout"
        self.stderr_path = cwd / "monitor.stderr"
        env = {**os.environ, "PYTHONPATH": str(REPO / "src"), "COLUMNS": "200", **(env or {})}
        self._out = open(self.stdout_path, "wb")
        self._err = open(self.stderr_path, "wb")
        self.proc = subprocess.Popen([sys.executable, "-m", "chronofuse.cli.main", "monitor", *args], cwd=cwd,
                                     stdout=self._out, stderr=self._err, env=env)

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors="replace")

    def wait_for_stderr(self, pattern: str, timeout_s: float = 30.0) -> re.Match:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            found = re.search(pattern, self.stderr())
            if found:
                return found
            if self.proc.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(f"no {pattern!r} on the monitor's stderr:\n{self.stderr()}")

    def url(self) -> str:
        return self.wait_for_stderr(r"dashboard at (http://\S+/)").group(1)

    def stop(self, timeout_s: float = 20.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._out.close()
        self._err.close()
        return self.proc.returncode


class Chronyd:
    """A real chronyd (Debian's) that does not control the system clock (``-x``), with its own pid,
    command socket, drift and dump files in a private directory, no NTP or command port, and a SOCK
    refclock ``CFSE`` at :attr:`refclock` (poll ``poll``: a sample may be up to 2^(poll+1) s old)."""

    def __init__(self, poll: int = 2) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="chronyd-"))
        self.dir.chmod(0o700)
        self.refclock = self.dir / "refclock.sock"
        self.command = self.dir / "chronyd.sock"
        conf = self.dir / "chrony.conf"
        conf.write_text("\n".join([
            f"refclock SOCK {self.refclock} refid CFSE poll {poll} filter 4",
            "port 0", "cmdport 0", f"bindcmdaddress {self.command}", f"pidfile {self.dir / 'chronyd.pid'}",
            f"driftfile {self.dir / 'drift'}", f"dumpdir {self.dir}", f"ntsdumpdir {self.dir}", ""]))
        self.log = open(self.dir / "chronyd.log", "wb")
        self.proc = subprocess.Popen([tool("chronyd"), "-x", "-d", "-u", "root", "-f", str(conf)],
                                     stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 15
        while not (self.refclock.exists() and self.command.exists()):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"chronyd did not start:\n{(self.dir / 'chronyd.log').read_text()}")
            time.sleep(0.05)

    def chronyc(self, *args: str) -> str:
        done = subprocess.run([tool("chronyc"), "-h", str(self.command), *args], capture_output=True, text=True,
                              timeout=15)
        assert done.returncode == 0, done.stderr
        return done.stdout

    def source(self) -> dict:
        """The CFSE line of ``chronyc -c sources`` and ``-c sourcestats`` as a dict."""
        sources = [line.split(",") for line in self.chronyc("-c", "sources").splitlines()]
        stats = [line.split(",") for line in self.chronyc("-c", "sourcestats").splitlines()]
        src = next(s for s in sources if s[2] == "CFSE")
        st = next(s for s in stats if s[0] == "CFSE")
        return {"state": src[1], "reach": int(src[5], 8), "last_rx_s": int(src[6]) if src[6] != "-" else None,
                "last_offset_s": float(src[7]), "samples": int(st[1]), "std_dev_s": float(st[7])}

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
        shutil.rmtree(self.dir, ignore_errors=True)
