"""How long work says how far it has got: ``progress(message, fraction=None)``.

A long job (a run, a GNSSDO simulation, the validation) calls ``progress`` at each stage with a line saying
what it does now and, where it knows it, the fraction of the whole job done before that stage (0..1). The
command line turns these into a bar with percentage and ETA on a terminal and plain lines off one
(:func:`chronofuse.cli.common.progress_reporter`); the library itself prints nothing. A job that runs
another as one of its stages hands it :func:`within`, which maps the inner job's 0..1 onto its own span.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Progress", "silent", "within"]

#: ``progress(message, fraction=None)``; ``fraction`` is of the whole job, 0..1, None where unknown.
Progress = Callable[..., None]


def silent(message: str, fraction: float | None = None) -> None:
    """The progress of a caller that asks for none."""


def within(progress: Progress, start: float, stop: float) -> Progress:
    """``progress`` for a stage that spans ``start..stop`` of the whole job: the stage's own fractions are
    mapped onto that span; a line without a fraction is reported at the last fraction the stage gave (its start at first)."""

    last = [0.0]

    def inner(message: str, fraction: float | None = None) -> None:
        if fraction is not None:
            last[0] = min(max(float(fraction), 0.0), 1.0)
        progress(message, start + (stop - start) * last[0])

    return inner
