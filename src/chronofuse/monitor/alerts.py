"""Alert hooks: a shell command and a webhook, each fired once per event.

The monitor's events are edges (:mod:`chronofuse.monitor.events`): an alarm held for forty epochs is one
``alarm_raised``, so a hook fires once for it, not forty times. By default the hooks fire on the events
that announce a problem (:data:`~chronofuse.monitor.events.ALARM_KINDS`: alarm raised, dissent, stale,
link down, jump).

- ``command``: run through the shell with the event as JSON on its standard input and in the environment
  (``CHRONOFUSE_RECEIVER``, ``CHRONOFUSE_EVENT`` (the kind), ``CHRONOFUSE_DETAIL``, ``CHRONOFUSE_WALL_S``,
  ``CHRONOFUSE_GPS_NS``), with a time limit;
- ``webhook``: the event as JSON, POSTed to the URL (``Content-Type: application/json``).

Hooks run concurrently on two bounded pools of threads (:data:`WORKERS` each; one for the command, one
for the webhook, so a slow command never delays a POST), each run limited to ``timeout_s`` (a command that
outlives it is killed with its whole process group); the monitor is never held back. A hook that fails
(exit status not 0, timeout, HTTP error) is reported through ``on_error`` with the event and the reason.
At :meth:`close` the hooks still pending are waited for (at most ``wait_s``; by default long enough for
every queued run to reach its own time limit), and any that could not run is reported, never dropped
silently.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import time
import urllib.request
from concurrent.futures import ThreadPoolExecutor

from chronofuse.monitor.events import ALARM_KINDS, MonitorEvent

__all__ = ["AlertHooks", "WORKERS"]

#: Threads per hook: as many runs of the command (or POSTs) at once.
WORKERS = 8


class AlertHooks:
    """Fire ``command`` and/or ``webhook`` once for each event of ``kinds`` (module docstring)."""

    def __init__(self, command: str | None = None, webhook: str | None = None, kinds=ALARM_KINDS,
                 timeout_s: float = 10.0, on_error=None) -> None:
        self.command, self.webhook, self.kinds = command, webhook, tuple(kinds)
        self.timeout_s = timeout_s
        self.on_error = on_error
        self.fired = 0
        self.failed = 0
        self._lock = threading.Lock()
        self._pending: set = set()
        self._pools = {kind: ThreadPoolExecutor(WORKERS, thread_name_prefix=f"chronofuse-{kind}")
                       for kind, on in (("command", command), ("webhook", webhook)) if on}

    def __call__(self, event: MonitorEvent) -> None:
        """Start the hooks for ``event`` when it is of a kind they fire on."""
        if event.kind not in self.kinds or not self._pools:
            return
        body = json.dumps(event.to_dict()).encode()
        for kind, pool in self._pools.items():
            run = self._run if kind == "command" else self._post
            future = pool.submit(run, event, body)
            with self._lock:
                self._pending.add((future, event, kind))
            future.add_done_callback(lambda f, item=(future, event, kind): self._done(item))

    def _done(self, item) -> None:
        with self._lock:
            self._pending.discard(item)

    def close(self, wait_s: float | None = None) -> None:
        """Wait for the pending hooks (at most ``wait_s``; None: until each queued run could reach its
        time limit), report those that did not run or finish, and stop the pools."""
        with self._lock:
            queued = len(self._pending)
        if wait_s is None:
            rounds = -(-queued // WORKERS) if queued else 0
            wait_s = rounds * (self.timeout_s + 1.0)
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            with self._lock:
                if not self._pending:
                    break
            time.sleep(0.02)
        with self._lock:
            left = list(self._pending)
        for future, event, kind in left:
            if future.cancel():
                self._failed(event, f"the {kind} hook did not run: the monitor ended")
        for pool in self._pools.values():
            pool.shutdown(wait=False, cancel_futures=True)

    def _run(self, event: MonitorEvent, body: bytes) -> None:
        env = {**os.environ, "CHRONOFUSE_RECEIVER": event.receiver, "CHRONOFUSE_EVENT": event.kind,
               "CHRONOFUSE_DETAIL": event.detail, "CHRONOFUSE_WALL_S": f"{event.wall_s:.3f}",
               "CHRONOFUSE_GPS_NS": "" if event.gps_ns is None else str(event.gps_ns)}
        proc = subprocess.Popen(self.command, shell=True, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, env=env, start_new_session=True)
        try:
            _, err = proc.communicate(body, timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # the shell and what it started
            except ProcessLookupError:
                pass
            proc.communicate()
            self._failed(event, f"the alarm command timed out after {self.timeout_s:g} s")
            return
        if proc.returncode != 0:
            tail = err.decode(errors="replace").strip().splitlines()[-1:] or [""]
            self._failed(event, f"the alarm command exited {proc.returncode} {tail[0]}".strip())
            return
        with self._lock:
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
        with self._lock:
            self.fired += 1

    def _failed(self, event: MonitorEvent, reason: str) -> None:
        with self._lock:
            self.failed += 1
        if self.on_error is not None:
            self.on_error(event, reason)
