"""The monitor's web face: a small threaded HTTP server (the standard library's) on a loopback address
by default.

``/``                      the dashboard (``dashboard.html`` beside this module: a live table per receiver,
                           charts of clock bias with alarms marked, a strip of each receiver's states)
``/events``                server-sent events (``text/event-stream``): one ``status`` message with the whole
                           status document each time the monitor publishes a new one
``/api/status``            the status document (JSON, :mod:`chronofuse.monitor.status`)
``/api/status.schema.json`` its JSON schema
``/metrics``               Prometheus text format (:mod:`chronofuse.monitor.metrics`)

The monitor loop calls :meth:`StatusServer.publish` with a new document (about four times a second);
each event-stream client waits on a condition for the next version, so an epoch reaches the page
within a refresh. The server never reads the monitor's state itself: it serves what was published,
so its threads and the loop share nothing else.
"""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from chronofuse.monitor.metrics import CONTENT_TYPE, metrics_text
from chronofuse.monitor.status import SCHEMA_PATH
from chronofuse.validation import InputDataError

__all__ = ["StatusServer", "parse_address"]

_PAGE = Path(__file__).with_name("dashboard.html")


def parse_address(text: str, name: str = "address") -> tuple[str, int]:
    """``HOST:PORT`` or ``:PORT`` (loopback) or ``PORT``; port 0 picks a free one."""
    host, sep, port = text.rpartition(":")
    if not sep:
        host, port = "", text
    try:
        number = int(port)
    except ValueError as err:
        raise InputDataError(f"{text!r}: expected HOST:PORT", name) from err
    if not 0 <= number <= 65535:
        raise InputDataError(f"{text!r}: port must be in 0..65535", name)
    return (host.strip("[]") or "127.0.0.1"), number


class StatusServer:
    """Serve published status documents over HTTP (module docstring)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0) -> None:
        self._cond = threading.Condition()
        self._version = 0
        self._doc: dict | None = None
        self._body = b"{}"
        self._closed = False
        self._page = _PAGE.read_bytes()
        self._schema = SCHEMA_PATH.read_bytes()
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args) -> None:  # quiet: the monitor's stderr carries events only
                pass

            def do_GET(self) -> None:
                path = self.path.split("?", 1)[0]
                if path in ("/", "/index.html"):
                    self._send(200, "text/html; charset=utf-8", server._page)
                elif path == "/api/status":
                    self._send(200, "application/json", server.current_body())
                elif path == "/api/status.schema.json":
                    self._send(200, "application/schema+json", server._schema)
                elif path == "/metrics":
                    doc = server.current()
                    self._send(200, CONTENT_TYPE, metrics_text(doc) if doc is not None else b"")
                elif path == "/events":
                    self._stream()
                else:
                    self._send(404, "text/plain", b"not found\n")

            def _send(self, code: int, kind: str, body: bytes) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def _stream(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "text/event-stream")
                self.send_header("Cache-Control", "no-store")
                self.send_header("Connection", "close")
                self.end_headers()
                seen = -1
                try:
                    while True:
                        version, body = server.wait_newer(seen, timeout_s=15.0)
                        if version is None:
                            return
                        if version == seen:
                            self.wfile.write(b": keep-alive\n\n")  # a comment line holds the connection open
                        else:
                            self.wfile.write(b"event: status\ndata: " + body + b"\n\n")
                            seen = version
                        self.wfile.flush()
                except (BrokenPipeError, ConnectionResetError):
                    return

        self.httpd = ThreadingHTTPServer((host, port), Handler)
        self.httpd.daemon_threads = True
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="chronofuse-http", daemon=True)

    @property
    def address(self) -> tuple[str, int]:
        return self.httpd.server_address[:2]

    @property
    def url(self) -> str:
        host, port = self.address
        return f"http://{host}:{port}/"

    def start(self) -> StatusServer:
        self._thread.start()
        return self

    def publish(self, doc: dict) -> None:
        """A new status document: served from now on and pushed to every event-stream client."""
        body = json.dumps(doc, separators=(",", ":"), allow_nan=False).encode()
        with self._cond:
            self._doc, self._body = doc, body
            self._version += 1
            self._cond.notify_all()

    def current(self) -> dict | None:
        with self._cond:
            return self._doc

    def current_body(self) -> bytes:
        with self._cond:
            return self._body

    def wait_newer(self, seen: int, timeout_s: float) -> tuple[int | None, bytes]:
        """The version and body newer than ``seen`` (or the same after ``timeout_s``); None once closed."""
        with self._cond:
            self._cond.wait_for(lambda: self._version != seen or self._closed, timeout=timeout_s)
            if self._closed:
                return None, b""
            return self._version, self._body

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self.httpd.shutdown()
        self.httpd.server_close()
