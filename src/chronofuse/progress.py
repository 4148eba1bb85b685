"""How long work says how far it has got: ``progress(message, fraction=None)``.

A long job (a run, a GNSSDO simulation, the validation) calls ``progress`` at each stage with a line saying
what it does now and, where it knows it, the fraction of the whole job done before that stage (0..1). The
command line turns these into a bar with percentage and ETA on a terminal and plain lines off one
(:func:`chronofuse.cli.common.progress_reporter`); the library itself prints nothing. A job that runs
another as one of its stages hands it :func:`within`, which maps the inner job's 0..1 onto its own span.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Progress", "silent", "stages", "within"]

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


def stages(progress: Progress, weights) -> list[Progress]:
    """One :func:`within` per stage of a job, in order, each spanning its share of the whole: ``weights`` are
    the stages' expected costs in any one unit (epochs simulated, trials x steps), so the ETA a display
    draws from the fractions is that of the work left, not of the stages left."""
    weights = [float(w) for w in weights]
    if not weights or min(weights) < 0 or sum(weights) <= 0:
        raise ValueError(f"weights == {weights}, must be >= 0 with a positive sum")
    total, edges = sum(weights), [0.0]
    for w in weights:
        edges.append(edges[-1] + w / total)
    edges[-1] = 1.0
    return [within(progress, a, b) for a, b in zip(edges[:-1], edges[1:])]
