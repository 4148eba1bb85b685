"""What the operator is told happened: edges of each receiver's state, each reported once.

A per-epoch flag that stays set (an alarm held for 40 epochs, a leap dissent that lasts) is one event
when it is raised and one when it clears, not one per epoch; a link that fails and is retried twenty
times before it comes back is one outage (``link_down`` with the first reason, ``link_up`` with its
duration and the number of attempts), not twenty. Kinds:

``link_down`` / ``link_up``   the source's device or socket went away / came (back), with the outage duration
``ended``                     a recording was read to its end
``stale`` / ``fresh``         no epoch for longer than the stale time / epochs again, with the silence
``alarm_raised`` / ``alarm_cleared``   the integrity alarm of the receiver's clock bias
``dissent`` / ``dissent_cleared``      its UTC label or leap count disagrees with the others (or the table)
``jump``                      a clock-bias jump of its own (instantaneous)
``frame_dropped``             frames its decoder could not read (a corrupt week or date): dropped, counted
``training_failed``           the integrity test could not be trained (too few valid epochs in the training
                              stretch): its epochs stay untested, never usable, until the grid starts again

The :class:`EventTracker` turns connection reports, decided records and freshness checks into
:class:`MonitorEvent` s; the monitor hands them to the log, stderr, the alert hooks and the web page.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

__all__ = ["MonitorEvent", "EventTracker", "EVENT_KINDS", "ALARM_KINDS"]

EVENT_KINDS = ("link_down", "link_up", "ended", "stale", "fresh", "alarm_raised", "alarm_cleared", "dissent",
               "dissent_cleared", "jump", "training_failed", "frame_dropped")
#: The events an alert hook fires on: a new problem with a receiver (its clearing is not an alert).
ALARM_KINDS = ("alarm_raised", "dissent", "stale", "link_down", "jump", "training_failed")


@dataclass(frozen=True)
class MonitorEvent:
    """One event: ``receiver``, ``kind`` (:data:`EVENT_KINDS`), ``wall_s`` (system clock, UNIX s),
    ``detail`` (a reason, in words), ``gps_ns`` (the epoch it belongs to, when it belongs to one) and
    ``duration_s`` (of the outage, silence, alarm or dissent that ended, when one did)."""

    receiver: str
    kind: str
    wall_s: float
    detail: str = ""
    gps_ns: int | None = None
    duration_s: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)

    def line(self) -> str:
        """One line for stderr: ``2026-12-01T23:02:10Z rx1 alarm_raised: statistic 53.1 ... (12.0 s)``."""
        stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self.wall_s))
        text = f"{stamp} {self.receiver} {self.kind}"
        if self.detail:
            text += f": {self.detail}"
        if self.duration_s is not None:
            text += f" (after {self.duration_s:.1f} s)"
        return text


@dataclass
class _State:
    link: str | None = None  # None (never reported), "up", "down", "ended"
    down_since_s: float | None = None
    down_reason: str = ""
    attempts: int = 0
    stale_since_s: float | None = None
    alarm_since: tuple | None = None  # (wall s, gps_ns)
    dissent_since: tuple | None = None
    training_failed: bool = False


@dataclass
class EventTracker:
    """Edges of each receiver's link, freshness, alarm and dissent (see the module docstring)."""

    states: dict = field(default_factory=dict)

    def _state(self, receiver: str) -> _State:
        return self.states.setdefault(receiver, _State())

    def link(self, receiver: str, kind: str, reason: str, wall_s: float) -> list[MonitorEvent]:
        """A source's connection report (``"up"``, ``"down"`` or ``"end"``)."""
        st = self._state(receiver)
        if kind == "up":
            was_down = st.link == "down"
            event = MonitorEvent(receiver, "link_up", wall_s,
                                 f"back after {st.attempts} failed attempt(s)" if was_down else "connected",
                                 duration_s=(wall_s - st.down_since_s) if was_down else None)
            st.link, st.down_since_s, st.attempts = "up", None, 0
            return [event]
        if kind == "down":
            if st.link == "down":
                st.attempts += 1
                return []  # a retry that failed again: the same outage
            st.link, st.down_since_s, st.down_reason, st.attempts = "down", wall_s, reason, 0
            return [MonitorEvent(receiver, "link_down", wall_s, reason)]
        if kind == "end":
            st.link = "ended"
            return [MonitorEvent(receiver, "ended", wall_s, "end of the recording")]
        return []

    def outage_s(self, receiver: str, wall_s: float) -> float | None:
        """How long the receiver's link has been down (None when it is not down)."""
        st = self._state(receiver)
        return None if st.down_since_s is None else wall_s - st.down_since_s

    def freshness(self, receiver: str, age_s: float | None, stale_s: float, wall_s: float,
                  first: bool = False) -> list[MonitorEvent]:
        """The receiver's last epoch is ``age_s`` old (None: none yet and no link; ``first``: none yet, its
        link up for ``age_s``): ``stale`` once it passes ``stale_s``, ``fresh`` when epochs come again."""
        st = self._state(receiver)
        if age_s is None or st.link == "ended":
            return []
        if age_s > stale_s and st.stale_since_s is None:
            st.stale_since_s = wall_s - age_s
            what = f"no epoch in {age_s:.1f} s since the link came up" if first else f"no epoch for {age_s:.1f} s"
            return [MonitorEvent(receiver, "stale", wall_s, f"{what} (stale after {stale_s:g} s)")]
        if age_s <= stale_s and st.stale_since_s is not None:
            silent = wall_s - age_s - st.stale_since_s
            st.stale_since_s = None
            return [MonitorEvent(receiver, "fresh", wall_s, "epochs again", duration_s=max(silent, 0.0))]
        return []

    def is_stale(self, receiver: str) -> bool:
        return self._state(receiver).stale_since_s is not None

    def records(self, records: list[dict], wall_s: float, training_reasons=lambda receiver: ()) -> list[MonitorEvent]:
        """Alarm and dissent edges, jumps and a failed training, of decided records (in time order);
        ``training_reasons(receiver)``: why its training failed, in words."""
        out = []
        for r in records:
            st = self._state(r["receiver"])
            gps_ns = int(r["gps_ns"])
            events = tuple(r.get("events") or ())
            if "training" in events:
                st.training_failed = False  # a grid started again trains again
            elif "training failed" in events and not st.training_failed:
                st.training_failed = True
                why = "; ".join(training_reasons(r["receiver"])) or "training failed"
                out.append(MonitorEvent(r["receiver"], "training_failed", wall_s,
                                        f"{why}: its epochs are not tested, not usable", gps_ns))
            flags = {"alarm": _alarmed(r), "dissent": bool(r.get("dissent"))}
            for flag, since_name, up, down, why in (
                    ("alarm", "alarm_since", "alarm_raised", "alarm_cleared", _alarm_detail),
                    ("dissent", "dissent_since", "dissent", "dissent_cleared", _dissent_detail)):
                since = getattr(st, since_name)
                if flags[flag] and since is None:
                    setattr(st, since_name, (wall_s, gps_ns))
                    out.append(MonitorEvent(r["receiver"], up, wall_s, why(r), gps_ns))
                elif not flags[flag] and since is not None:
                    setattr(st, since_name, None)
                    out.append(MonitorEvent(r["receiver"], down, wall_s, f"at {r.get('utc', gps_ns)}", gps_ns,
                                            duration_s=(gps_ns - since[1]) / 1e9))
            if r.get("jump"):
                out.append(MonitorEvent(r["receiver"], "jump", wall_s, f"clock-bias jump at {r.get('utc', gps_ns)}",
                                        gps_ns))
        return out


def _alarmed(r: dict) -> bool:
    """The integrity alarm as the detection pipeline latches it (its ``state``), else the epoch's own flag."""
    return r["state"] == "alarm" if "state" in r else bool(r.get("alarm"))


def _alarm_detail(r: dict) -> str:
    stat = r.get("statistic")
    text = f"at {r.get('utc', r['gps_ns'])}"
    if isinstance(stat, float) and math.isfinite(stat):
        text += f", test statistic {stat:.1f}"
    return text


def _dissent_detail(r: dict) -> str:
    off = int(r.get("dissent_s") or 0)
    if off:
        return f"at {r.get('utc', r['gps_ns'])}, its time {off:+d} s from the other receivers' (on arrival)"
    return f"at {r.get('utc', r['gps_ns'])}, its leap count {r.get('leap_s')} s"
