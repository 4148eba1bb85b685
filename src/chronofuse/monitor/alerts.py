"""Alert hooks: a shell command and a webhook, each fired once per event.

The monitor's events are edges (:mod:`chronofuse.monitor.events`): an alarm held for forty epochs is one
``alarm_raised``, so a hook fires once for it, not forty times. By default the hooks fire on the events
that announce a problem (:data:`~chronofuse.monitor.events.ALARM_KINDS`: alarm raised, dissent, stale,
link down, jump).

- ``command``: run through the shell with the event as JSON on its standard input and in the environment
  (``CHRONOFUSE_RECEIVER``, ``CHRONOFUSE_EVENT`` (the kind), ``CHRONOFUSE_DETAIL``, ``CHRONOFUSE_WALL_S``,
  ``CHRONOFUSE_GPS_NS``), with a time limit;
- ``webhook``: the event as JSON, POSTed to the URL (``Content-Type: application/json``).

Hooks run on a worker thread, in event order, so a slow command or an unreachable URL never holds the
monitor back; a hook that fails (exit status not 0, timeout, HTTP error) is reported through ``on_error``
with the event and the reason, and the next event is tried as usual.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import threading
import urllib.request

from chronofuse.monitor.events import ALARM_KINDS, MonitorEvent

__all__ = ["AlertHooks"]


class AlertHooks:
    """Fire ``command`` and/or ``webhook`` once for each event of ``kinds`` (module docstring)."""

    def __init__(self, command: str | None = None, webhook: str | None = None, kinds=ALARM_KINDS,
                 timeout_s: float = 10.0, on_error=None) -> None:
        self.command, self.webhook, self.kinds = command, webhook, tuple(kinds)
        self.timeout_s = timeout_s
        self.on_error = on_error
        self.fired = 0
        self.failed = 0
        self._queue: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="chronofuse-alerts", daemon=True)
        self._thread.start()

    def __call__(self, event: MonitorEvent) -> None:
        """Queue ``event`` for the hooks when it is of a kind they fire on."""
        if event.kind in self.kinds and (self.command or self.webhook):
            self._queue.put(event)

    def close(self, wait_s: float = 15.0) -> None:
        """Let queued hooks finish (at most ``wait_s``), then stop the worker."""
        self._queue.put(None)
        self._thread.join(wait_s)

    def _work(self) -> None:
        while True:
            event = self._queue.get()
            if event is None:
                return
            body = json.dumps(event.to_dict()).encode()
            if self.command:
                self._run(event, body)
            if self.webhook:
                self._post(event, body)

    def _run(self, event: MonitorEvent, body: bytes) -> None:
        env = {**os.environ, "CHRONOFUSE_RECEIVER": event.receiver, "CHRONOFUSE_EVENT": event.kind,
               "CHRONOFUSE_DETAIL": event.detail, "CHRONOFUSE_WALL_S": f"{event.wall_s:.3f}",
               "CHRONOFUSE_GPS_NS": "" if event.gps_ns is None else str(event.gps_ns)}
        try:
            done = subprocess.run(self.command, shell=True, input=body, env=env, timeout=self.timeout_s,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        except subprocess.TimeoutExpired:
            self._failed(event, f"the alarm command timed out after {self.timeout_s:g} s")
            return
        if done.returncode != 0:
            tail = done.stderr.decode(errors="replace").strip().splitlines()[-1:] or [""]
            self._failed(event, f"the alarm command exited {done.returncode} {tail[0]}".strip())
            return
        self.fired += 1

    def _post(self, event: MonitorEvent, body: bytes) -> None:
        request = urllib.request.Request(self.webhook, data=body, method="POST",
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s) as reply:
                reply.read()
        except (OSError, ValueError) as err:  # URLError, HTTPError and timeouts are OSErrors
            self._failed(event, f"webhook {self.webhook}: {err}")
            return
        self.fired += 1

    def _failed(self, event: MonitorEvent, reason: str) -> None:
        self.failed += 1
        if self.on_error is not None:
            self.on_error(event, reason)
