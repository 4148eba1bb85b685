"""Where receiver bytes come from: files (plain or gzip), serial ports (pyserial), TCP streams of raw
NMEA/UBX, and a gpsd server's JSON; several at once; reconnecting with backoff when one drops.

Every source runs in its own thread (:class:`SourceGroup`) and puts :class:`SourceEvent` s on one queue:
``"up"`` when it connects, ``"data"`` with bytes, ``"down"`` with the reason when the device or socket
goes away, ``"end"`` when a file is read out. A dropped serial device or socket is retried with
exponential backoff (:class:`Backoff`: 0.1 s doubling to 5 s, reset by a success), so a receiver
unplugged and plugged back, or a server restarted, is picked up again without the monitor noticing
more than an outage.

Source specs on the command line (:func:`parse_source`): ``file:PATH`` or a plain path, ``serial:/dev/ttyUSB0@115200``,
``tcp:HOST:PORT``, ``gpsd:HOST:PORT`` (default port 2947).
"""

from __future__ import annotations

import queue
from abc import ABC, abstractmethod
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from chronofuse.io.formats import open_data
from chronofuse.validation import InputError

__all__ = ["Backoff", "SourceEvent", "FileSource", "SerialSource", "TcpSource", "GpsdSource", "SourceGroup",
           "parse_source"]

_CHUNK = 65536
GPSD_WATCH = b'?WATCH={"enable":true,"json":true,"pps":true};\n'


@dataclass(frozen=True)
class SourceEvent:
    """``kind``: "up", "data", "down" or "end"; ``data``: bytes for "data", the reason for "down";
    ``time_s``: the monotonic clock when it was read; ``wall_ns``: the system clock then (UNIX ns), the
    arrival time a time server needs."""

    source: str
    kind: str
    data: bytes | str = b""
    time_s: float = 0.0
    wall_ns: int = 0


class Backoff:
    """Exponential backoff: ``next()`` gives ``initial_s``, then doubles up to ``max_s``; ``reset()``."""

    def __init__(self, initial_s: float = 0.1, max_s: float = 5.0, factor: float = 2.0) -> None:
        self.initial_s, self.max_s, self.factor = initial_s, max_s, factor
        self._next = initial_s

    def next(self) -> float:
        delay = self._next
        self._next = min(self._next * self.factor, self.max_s)
        return delay

    def reset(self) -> None:
        self._next = self.initial_s


class _Source(ABC):
    kind = "raw"  # "raw" NMEA/UBX bytes, or "gpsd" JSON lines

    def __init__(self, name: str) -> None:
        self.name = name

    @abstractmethod
    def run(self, emit, stop: threading.Event) -> None:
        """Read until ``stop`` is set (or the source ends), calling ``emit(kind, data)``."""


class FileSource(_Source):
    """A recording (gzip told by its content), read in chunks; ``rate_bytes_s`` paces the bytes
    (a replay at a chosen speed), None reads as fast as the consumer takes them."""

    def __init__(self, path, name: str | None = None, rate_bytes_s: float | None = None, chunk: int = _CHUNK):
        super().__init__(name or Path(path).name)
        self.path, self.rate_bytes_s, self.chunk = Path(path), rate_bytes_s, chunk

    def run(self, emit, stop: threading.Event) -> None:
        try:
            stream = open_data(self.path)
        except OSError as err:
            emit("down", f"{type(err).__name__}: {err}")
            emit("end")
            return
        emit("up")
        start, sent = time.monotonic(), 0
        with stream:
            while not stop.is_set():
                data = stream.read(self.chunk)
                if not data:
                    break
                emit("data", data)
                sent += len(data)
                if self.rate_bytes_s:
                    ahead = sent / self.rate_bytes_s - (time.monotonic() - start)
                    if ahead > 0:
                        stop.wait(ahead)
        emit("end")


class _Reconnecting(_Source):
    """A source that opens a connection, reads until it fails, and opens it again after a backoff."""

    def __init__(self, name: str, backoff: Backoff | None = None) -> None:
        super().__init__(name)
        self.backoff = backoff or Backoff()

    def run(self, emit, stop: threading.Event) -> None:
        while not stop.is_set():
            try:
                conn = self.open()
            except OSError as err:
                emit("down", f"cannot open: {type(err).__name__}: {err}")
                stop.wait(self.backoff.next())
                continue
            emit("up")
            self.backoff.reset()
            try:
                while not stop.is_set():
                    data = self.read(conn)
                    if data is None:
                        continue  # a read timeout: nothing yet
                    if not data:
                        raise ConnectionError("closed by the other end")
                    emit("data", data)
            except (OSError, ConnectionError) as err:
                emit("down", f"{type(err).__name__}: {err}")
            finally:
                self.close(conn)
            stop.wait(self.backoff.next())

    @abstractmethod
    def open(self):
        """Open the connection (raise OSError when it cannot be opened)."""

    @abstractmethod
    def read(self, conn):
        """Bytes read, None on a read timeout, b"" (or ConnectionError/OSError) when the link is gone."""

    def close(self, conn) -> None:
        try:
            conn.close()
        except OSError:
            pass


class SerialSource(_Reconnecting):
    """A serial port through pyserial (``port`` like ``/dev/ttyUSB0``; a pseudo-terminal works too)."""

    def __init__(self, port: str, baudrate: int = 9600, name: str | None = None, backoff: Backoff | None = None):
        from chronofuse.extras import require

        require("serial", f"the serial source {port}")  # here, not in the reading thread: one line, exit 2
        super().__init__(name or port, backoff)
        self.port, self.baudrate = port, baudrate

    def open(self):
        import serial  # pyserial, imported here so that file-only users do not need it

        try:
            return serial.Serial(self.port, self.baudrate, timeout=0.2)
        except (serial.SerialException, ValueError) as err:  # ValueError: a setting the port refuses
            raise OSError(str(err)) from err

    def read(self, conn):
        import serial

        try:
            waiting = conn.in_waiting
            data = conn.read(max(1, min(waiting, _CHUNK)))
        except serial.SerialException as err:
            raise OSError(str(err)) from err
        if not data:
            # pyserial returns b"" both on a timeout and when a pseudo-terminal's other end is gone;
            # the port's file still being there tells them apart
            if not Path(self.port).exists():
                raise ConnectionError("the device went away")
            return None
        return data


class TcpSource(_Reconnecting):
    """A TCP stream of raw NMEA/UBX (a receiver's network port, ser2net, str2str)."""

    def __init__(self, host: str, port: int, name: str | None = None, backoff: Backoff | None = None,
                 greeting: bytes = b""):
        super().__init__(name or f"{host}:{port}", backoff)
        self.host, self.port, self.greeting = host, int(port), greeting

    def open(self):
        conn = socket.create_connection((self.host, self.port), timeout=2.0)
        conn.settimeout(0.5)
        if self.greeting:
            conn.sendall(self.greeting)
        return conn

    def read(self, conn):
        try:
            return conn.recv(_CHUNK)
        except socket.timeout:
            return None


class GpsdSource(TcpSource):
    """A gpsd server: asks for its JSON reports (``?WATCH``) and passes the lines on."""

    kind = "gpsd"

    def __init__(self, host: str = "127.0.0.1", port: int = 2947, name: str | None = None,
                 backoff: Backoff | None = None):
        super().__init__(host, port, name or f"gpsd:{host}:{port}", backoff, greeting=GPSD_WATCH)


class SourceGroup:
    """Several sources read at once, each in its own thread, their events on one queue."""

    def __init__(self, sources) -> None:
        self.sources = list(sources)
        self.events: queue.Queue[SourceEvent] = queue.Queue(maxsize=10_000)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def start(self) -> SourceGroup:
        for source in self.sources:
            def emit(kind, data=b"", at_s=None, _name=source.name):
                # ``at_s``: the monotonic instant the data is due (a replay's schedule), stamped as its arrival
                mono, wall = time.monotonic(), time.time_ns()
                if at_s is not None and at_s < mono:
                    mono, wall = at_s, wall - int(round((mono - at_s) * 1e9))
                event = SourceEvent(_name, kind, data, mono, wall)
                while not self._stop.is_set():  # a full queue waits for the consumer, not past a stop
                    try:
                        self.events.put(event, timeout=0.1)
                        return
                    except queue.Full:
                        continue

            thread = threading.Thread(target=source.run, args=(emit, self._stop), name=source.name, daemon=True)
            thread.start()
            self._threads.append(thread)
        return self

    def get(self, timeout_s: float = 0.5) -> SourceEvent | None:
        try:
            return self.events.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def stop(self, join_s: float = 2.0) -> None:
        """Stop every source thread (at most ``join_s`` in all for the stragglers)."""
        self._stop.set()
        deadline = time.monotonic() + join_s
        for thread in self._threads:
            thread.join(max(deadline - time.monotonic(), 0.0))

    def __enter__(self) -> SourceGroup:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def _port(text: str, spec: str) -> int:
    port = int(text)
    if not 0 < port < 65536:
        raise InputError(f"source {spec!r}: port {port}, must be 1 to 65535")
    return port


def parse_source(spec: str):
    """A source from its command-line spec (see the module docstring); raises InputError naming it (a baud
    rate that is not a positive whole number, a port outside 1-65535, no host)."""
    kind, _, rest = spec.partition(":")
    try:
        if kind == "serial":
            port, _, baud = rest.partition("@")
            if not port:
                raise InputError(f"source {spec!r}: no serial port (serial:/dev/ttyUSB0@9600)")
            rate = int(baud) if baud else 9600
            if rate <= 0:
                raise InputError(f"source {spec!r}: baud rate {rate}, must be > 0")
            return SerialSource(port, rate)
        if kind == "tcp":
            host, _, port = rest.rpartition(":")
            if not host:
                raise InputError(f"source {spec!r}: no host (tcp:HOST:PORT)")
            return TcpSource(host, _port(port, spec))
        if kind == "gpsd":
            host, _, port = rest.rpartition(":") if rest.count(":") else (rest, "", "2947")
            return GpsdSource(host or "127.0.0.1", _port(port or "2947", spec))
        if kind == "file":
            return FileSource(rest)
    except InputError:
        raise
    except ValueError as err:
        raise InputError(f"source {spec!r}: {err}") from err
    return FileSource(spec)
