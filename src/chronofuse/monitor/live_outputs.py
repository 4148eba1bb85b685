"""Where a running monitor's results go, composed once: JSON lines (stdout and/or a file), event lines
on stderr, the live table, the web server, the alert hooks and the chrony feed.

:class:`LiveOutputs` is handed to :class:`~chronofuse.monitor.engine.Monitor` as its ``on_ack``
(:meth:`records`: called after each commit), ``on_event`` (:meth:`event`: after the event is logged) and
``on_tick`` (:meth:`tick`: about four times a second). The live table is drawn on the console (stderr)
without capturing stdout, so JSON lines on stdout or in a file are written whether or not the table is
shown; event lines are printed above the table.
"""

from __future__ import annotations

import json
import math
import os
import sys
from contextlib import contextmanager

from chronofuse.monitor.status import RecentEvents, status_document
from chronofuse.validation import InputError

__all__ = ["LiveOutputs", "OutputClosed"]


class OutputClosed(Exception):
    """The reader of the JSON lines on stdout went away (``| head -1``): the run stops, quietly."""


def _line(record: dict) -> str:
    doc = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in record.items()}
    return json.dumps(doc, separators=(",", ":"))


class LiveOutputs:
    """The outputs of one monitor run (module docstring). ``http_address``: (host, port) or None;
    ``chrony_sock``: the SOCK refclock path or None; ``replayed``: the sources are recordings (the chrony
    feed then shifts their time to now); ``table``: draw the live table on ``console``."""

    def __init__(self, *, json_lines: bool = False, lines_file=None, http_address=None, on_alarm: str | None = None,
                 webhook: str | None = None, chrony_sock=None, replayed: bool = False, table: bool = False,
                 console=None) -> None:
        self.json_lines = json_lines
        self.lines_file = lines_file
        self.http_address = http_address
        self.table = table
        self.console = console
        self.recent = RecentEvents()
        self.monitor = None
        self.server = None
        self.live = None
        self.alerts = None
        if on_alarm or webhook:
            from chronofuse.monitor.alerts import AlertHooks

            self.alerts = AlertHooks(on_alarm, webhook, on_error=lambda ev, why: self.say(f"alert hook failed for "
                                                                                       f"{ev.receiver} {ev.kind}: {why}"))
        self.chrony = None
        if chrony_sock is not None:
            from chronofuse.monitor.chrony import ChronySockFeed

            self.chrony = ChronySockFeed(str(chrony_sock), shift_to_now=replayed, on_error=self.say)

    def attach(self, monitor) -> None:
        self.monitor = monitor

    def say(self, text: str) -> None:
        """One line on stderr (above the live table when it is shown)."""
        if self.live is not None:
            self.live.console.print(text, markup=False, highlight=False, soft_wrap=True)
        elif self.console is not None:
            self.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            sys.stderr.write(text + "\n")

    def records(self, records: list[dict]) -> None:
        """Committed records: JSON lines, then the chrony feed."""
        if self.json_lines or self.lines_file is not None:
            text = "".join(_line(r) + "\n" for r in records)
            if self.json_lines:
                try:
                    sys.stdout.write(text)
                    sys.stdout.flush()
                except BrokenPipeError:
                    # as a Unix tool does: stop, say nothing; stdout to /dev/null so that the interpreter's
                    # last flush does not complain
                    self.json_lines = False
                    devnull = os.open(os.devnull, os.O_WRONLY)
                    os.dup2(devnull, sys.stdout.fileno())
                    os.close(devnull)
                    raise OutputClosed() from None
            if self.lines_file is not None:
                self.lines_file.write(text)
                self.lines_file.flush()
        if self.chrony is not None:
            mon = self.monitor
            self.chrony.feed(records, mon.is_stale if mon is not None else (lambda name: False))

    def event(self, event) -> None:
        """A logged event: a line on stderr, the alert hooks, the page's event list."""
        self.recent.append(event)
        self.say(event.line())
        if self.alerts is not None:
            self.alerts(event)

    def status(self) -> dict:
        return status_document(self.monitor, list(self.recent),
                               chrony=self.chrony.state() if self.chrony is not None else None)

    def tick(self, monitor) -> None:
        if self.server is None and self.live is None:
            return
        doc = self.status()
        if self.server is not None:
            self.server.publish(doc)
        if self.live is not None:
            from chronofuse.monitor.table import receiver_table

            self.live.update(receiver_table(monitor, width=self.live.console.width, doc=doc))

    def alert_counts(self) -> dict | None:
        return None if self.alerts is None else {"fired": self.alerts.fired, "failed": self.alerts.failed}

    def listen(self) -> None:
        """Bind the web server (before the run, so that an address that cannot be had is refused first):
        raises :class:`InputError` naming the ``http`` field (a port in use, an address not on this host)."""
        if self.http_address is None or self.server is not None:
            return
        from chronofuse.monitor.web import StatusServer

        host, port = self.http_address
        try:
            self.server = StatusServer(host, port).start()
        except OSError as err:
            raise InputError(f"{{http}} {host}:{port}: cannot listen there ({err.strerror or err})",
                             fields=("http",)) from err

    @contextmanager
    def running(self):
        """Start the web server and the live table for the run; stop them (and the hooks) after it."""
        try:
            if self.http_address is not None:
                self.listen()
                self.say(f"dashboard at {self.server.url} (/api/status, /metrics)")
                if self.monitor is not None:
                    self.server.publish(self.status())
            if self.table and self.console is not None:
                from rich.live import Live

                from chronofuse.monitor.table import receiver_table

                self.live = Live(receiver_table(self.monitor, width=self.console.width), console=self.console,
                                 refresh_per_second=4, transient=False, redirect_stdout=False, redirect_stderr=False)
                self.live.start()
            yield self
        finally:
            if self.live is not None:
                self.live.stop()
                self.live = None
            if self.server is not None:
                self.server.publish(self.status())
                self.server.close()
            if self.alerts is not None:
                self.alerts.close()
            if self.chrony is not None:
                self.chrony.close()
