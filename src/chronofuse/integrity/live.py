"""Clock-bias detection on a text stream, epoch by epoch: standard input, a pipe, a FIFO (issue 10.6).

:func:`stream_verdicts` reads ``time,clock_bias`` lines as they arrive and yields one
:class:`~chronofuse.integrity.streaming.EpochVerdict` per epoch through
:class:`~chronofuse.integrity.streaming.StreamingMonitor` (the per-epoch path the live monitor uses);
``chronofuse detect - --json-lines`` prints each as one JSON line and flushes it. Nothing is read ahead:
a line is turned into its verdict before the next one is read, so a FIFO or a pipe from a receiver works.

Lines: an optional header (any line whose first field is not a number) names the columns; the time is the
first column (seconds, or nanoseconds when its name ends in ``_ns``), the bias is ``column`` if given, else
the first name starting with ``clock_bias``, else the second column (seconds, scaled by a ``_ns``/``_us``/
``_ms`` suffix). Empty lines and lines starting with ``#`` are skipped. The interval is ``1/rate_hz`` when
given, else the spacing of the first two epochs; epochs missing from the stream (a time step of several
intervals) are fed as missing (NaN) epochs, so the difference chain restarts after a gap.

Noise model: given (``h0``, ``hm2``, ``sigma_rho_m``), or learnt from the first ``train_s`` seconds, which
are reported ``unavailable`` with the event ``training`` while they arrive; at the end of the stretch the
detector is fitted (with the confidence margin of :data:`chronofuse.integrity.modes.TRAINING_CONFIDENCE`),
the training epochs are stepped through silently to fill its window, and testing starts with the next
epoch. The verdicts equal the batch :func:`chronofuse.integrity.modes.detect_file` on the same data.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

from chronofuse.integrity.streaming import EpochVerdict, StreamingMonitor
from chronofuse.validation import InputDataError

_UNIT = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def _columns(header: list[str], column: str | None) -> tuple[int, float, float]:
    """``(bias column index, bias scale to s, time scale to ns)`` from a header (or none: ``[]``)."""
    names = [h.strip().lower() for h in header]
    time_scale = 1.0 if names and names[0].endswith("_ns") else 1e9
    if column is not None:
        if column.lower() not in names:
            raise InputDataError(f"column {column!r} not found among {header}", "<stream>")
        idx = names.index(column.lower())
    else:
        idx = next((i for i, n in enumerate(names) if n.startswith("clock_bias")), 1)
    name = names[idx] if idx < len(names) else ""
    unit = name.rsplit("_", 1)[-1] if "_" in name else "s"
    return idx, _UNIT.get(unit, 1.0), time_scale


def _epochs(lines: Iterable[str], column: str | None) -> Iterator[tuple[int, float, int]]:
    """``(t_ns, bias_s, line number)`` per data line."""
    idx, scale, time_scale = None, 1.0, 1e9
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.replace(";", ",").split(",")]
        try:
            t = float(fields[0])
        except ValueError:
            if idx is None:
                idx, scale, time_scale = _columns(fields, column)
                continue
            raise InputDataError(f"time {fields[0]!r} is not a number", f"<stream>:{number}") from None
        if idx is None:
            idx, scale, time_scale = _columns([], column)
        try:
            bias = float(fields[idx]) * scale
        except (ValueError, IndexError):
            raise InputDataError(f"no clock bias number in {line!r}", f"<stream>:{number}") from None
        yield int(round(t * time_scale)), bias, number


def stream_verdicts(
    lines: Iterable[str],
    *,
    rate_hz: float | None = None,
    column: str | None = None,
    window: int = 20,
    pfa: float = 1e-3,
    h0: float | None = None,
    hm2: float | None = None,
    sigma_rho_m: float | None = None,
    train_s: float | None = None,
    detector: str = "chi-square",
) -> Iterator[EpochVerdict]:
    """One verdict per epoch of the ``time,clock_bias`` text ``lines`` (module docstring), as they arrive.

    ``detector``: a name of :data:`chronofuse.integrity.registry.DETECTORS`, as in
    :func:`chronofuse.integrity.modes.detect_file`."""
    from chronofuse.integrity.modes import TRAINING_CONFIDENCE, _detector_factory

    if train_s is None and None in (h0, hm2, sigma_rho_m):
        raise ValueError("give the noise model (h0, hm2 and sigma_rho_m) or a training stretch (train_s)")
    step_ns = None if rate_hz is None else int(round(1e9 / rate_hz))
    monitor: StreamingMonitor | None = None
    training: list[tuple[int, float]] = []
    t0 = last = None
    make = _detector_factory(detector, window=window, pfa=pfa, h0=h0, hm2=hm2, sigma_rho_m=sigma_rho_m,
                             confidence=TRAINING_CONFIDENCE if train_s is not None else None)

    def start(interval_ns: int) -> StreamingMonitor:
        det = make(interval_ns / 1e9)
        if train_s is None:
            return StreamingMonitor(det.fit())
        import numpy as np

        from chronofuse.integrity.clock_events import repair_clock_steering

        values = np.array([b for _, b in training])
        det.fit(repair_clock_steering(values).repaired_s)
        mon = StreamingMonitor(det)
        left_outs = getattr(det, "training_outliers_", np.zeros(len(training), dtype=bool))
        for (t, b), left_out in zip(training, left_outs):
            mon.step(t, math.nan if left_out else b)  # training outliers are out of the window, as in the batch
        return mon

    for t_ns, bias, number in _epochs(lines, column):
        if last is not None and t_ns <= last:
            raise InputDataError(f"time is not increasing ({last} ns then {t_ns} ns)", f"<stream>:{number}")
        if last is not None and step_ns is None:
            step_ns = t_ns - last
        fill = []
        if last is not None:
            k = (t_ns - last) / step_ns
            if abs(k - round(k)) > 1e-6 or round(k) < 1:
                raise InputDataError(f"time step {(t_ns - last) / 1e9:g} s is not a whole number of intervals "
                                     f"({step_ns / 1e9:g} s)", f"<stream>:{number}")
            fill = [last + j * step_ns for j in range(1, int(round(k)))]
        t0 = t_ns if t0 is None else t0
        for t, b in [*((tf, math.nan) for tf in fill), (t_ns, bias)]:
            if monitor is None and train_s is not None and (t - t0) / 1e9 < train_s:
                training.append((t, b))
                yield EpochVerdict(t, math.nan, math.nan, False, "unavailable", ("training",))
                continue
            if monitor is None:
                if step_ns is None:
                    training.append((t, b))
                    yield EpochVerdict(t, math.nan, math.nan, False, "unavailable", ())
                    continue
                monitor = start(step_ns)
                if train_s is None:
                    for tt, bb in training:
                        monitor.step(tt, bb)
            yield monitor.step(t, b)
        last = t_ns


def follow_lines(stream, *, idle_s: float = 10.0, poll_s: float = 0.2) -> Iterator[str]:
    """The complete lines of a file that is still being written (``tail -f``): at the end of the file wait
    ``poll_s`` and read again; stop when nothing new has come for ``idle_s`` seconds. A last line without
    its newline is held back until it is complete (or the stream ends)."""
    import time

    pending = ""
    quiet_since = time.monotonic()
    while True:
        chunk = stream.readline()
        if chunk:
            quiet_since = time.monotonic()
            pending += chunk
            if pending.endswith("\n"):
                yield pending
                pending = ""
            continue
        if time.monotonic() - quiet_since >= idle_s:
            if pending:
                yield pending
            return
        time.sleep(poll_s)


__all__ = ["follow_lines", "stream_verdicts"]
