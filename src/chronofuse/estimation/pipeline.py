"""Pipelines of stages: one program for the batch path and the live path.

A **stage** is an estimator (:mod:`chronofuse.estimation.interface`) whose measurement is a named epoch
rather than one number: it reads the columns it ``needs`` and adds the columns it ``gives``::

    stage.fit(frame=None) -> stage       # learn from a training frame (columns of shape (..., steps)); reset
    stage.reset()                        # forget the streaming state
    stage.step(epoch) -> dict            # one epoch: a mapping name -> value (scalar, or an array of the lead axes)
    stage.run(frame) -> dict             # every epoch: name -> array (..., steps); never mutates the stage

A :class:`Pipeline` chains stages, each seeing the columns of the record and of the stages before it, and is
itself an estimator with the same four calls: ``run`` over a batch is each stage's ``run`` in turn, ``step``
each stage's ``step`` in turn, and every stage's ``step`` and ``run`` share one core, so a pipeline streamed
epoch by epoch gives what it gives in batch (:func:`compare_streaming_to_batch` checks it on whole
pipelines). ``fit`` fits the stages in order, each on the training frame as the fitted stages before it
transform it (a detector is fitted on the clock bias after the clock repair).

Columns are named by the stage that makes them (one name, one meaning, a unit in the name where it has one:
``statistic``, ``clock_reset_s``); a stage may not give a column an earlier one gives (checked when the
pipeline is built). The epoch's time tag ``t_ns`` (int64 ns) and the source's ``valid`` flag are columns
like the others. A later issue's stage (a plausibility monitor, a stale-receiver check) is one more
``(name, stage)`` entry, not a new path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from chronofuse.estimation.interface import readonly

__all__ = ["Stage", "Pipeline", "PipelineStep", "PipelineResult", "compare_streaming_to_batch", "stack_steps"]


@runtime_checkable
class Stage(Protocol):
    """One stage of a :class:`Pipeline` (module docstring)."""

    needs: ClassVar[tuple[str, ...]]
    gives: ClassVar[tuple[str, ...]]

    def fit(self, frame: Mapping[str, np.ndarray] | None = None) -> Stage: ...

    def reset(self) -> None: ...

    def step(self, epoch: Mapping[str, Any]) -> dict[str, Any]: ...

    def run(self, frame: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]: ...


@dataclasses.dataclass(frozen=True)
class PipelineStep:
    """One epoch through a pipeline: every column (the inputs and what each stage gave), read-only."""

    values: Mapping[str, Any]

    def __post_init__(self):
        if not isinstance(self.values, MappingProxyType):
            object.__setattr__(self, "values", MappingProxyType(dict(self.values)))

    def __getitem__(self, name: str):
        return self.values[name]

    def get(self, name: str, default=None):
        return self.values.get(name, default)


@dataclasses.dataclass(frozen=True)
class PipelineResult:
    """A batch through a pipeline: every column, arrays (..., steps) made read-only."""

    columns: Mapping[str, np.ndarray]

    def __post_init__(self):
        object.__setattr__(self, "columns", MappingProxyType({n: readonly(v) for n, v in self.columns.items()}))

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns


def _frame(data) -> dict[str, np.ndarray]:
    if hasattr(data, "frame") and callable(data.frame):  # an EpochRecord
        return data.frame()
    return dict(data)


class Pipeline:
    """Stages run in order (module docstring); a pipeline is an estimator too.

    ``stages``: ``(name, stage)`` pairs; ``inputs`` (read-only): the columns the stages need that no stage
    before them gives (what a record must carry).
    """

    def __init__(self, stages: Sequence[tuple[str, Stage]]):
        self.stages = tuple(stages)
        given: set[str] = set()
        needed: list[str] = []
        names = [name for name, _ in self.stages]
        if len(set(names)) != len(names):
            raise ValueError(f"stage names repeat: {names}")
        for name, stage in self.stages:
            needed += [c for c in stage.needs if c not in given and c not in needed]
            clash = set(stage.gives) & given
            if clash:
                raise ValueError(f"stage {name!r} gives {sorted(clash)}, already given by an earlier stage")
            given |= set(stage.gives)
        self.inputs = tuple(needed)
        self.gives = tuple(given)

    def __getitem__(self, name: str) -> Stage:
        for stage_name, stage in self.stages:
            if stage_name == name:
                return stage
        raise KeyError(f"no stage {name!r} (stages: {[n for n, _ in self.stages]})")

    def fit(self, frame=None) -> Pipeline:
        """Fit each stage on ``frame`` (a record or columns) as the stages before it transform it; reset."""
        data = None if frame is None else _frame(frame)
        for _, stage in self.stages:
            stage.fit(data)
            if data is not None:
                data.update(stage.run(data))
        return self

    def reset(self) -> None:
        for _, stage in self.stages:
            stage.reset()

    def step(self, epoch: Mapping[str, Any]) -> PipelineStep:
        """One epoch (a mapping of the input columns to their values) through every stage."""
        values = dict(epoch)
        for _, stage in self.stages:
            values.update(stage.step(values))
        return PipelineStep(MappingProxyType(values))  # a fresh dict: no copy needed

    def run(self, frame) -> PipelineResult:
        """Every epoch of ``frame`` (a record, or columns (..., steps)) through every stage; mutates nothing."""
        data = _frame(frame)
        for _, stage in self.stages:
            data.update(stage.run(data))
        return PipelineResult(data)


def stack_steps(steps: Sequence[PipelineStep], names: Sequence[str]) -> dict[str, np.ndarray]:
    """Streamed epochs as batch columns: ``name -> array (..., steps)`` (the step axis last)."""
    out = {}
    for name in names:
        values = [s[name] for s in steps]
        if values and isinstance(values[0], (str, tuple)):
            a = np.empty(len(values), dtype=object)
            a[:] = values
        else:
            a = np.array(values)
        out[name] = np.moveaxis(a, 0, -1) if a.ndim > 1 else a
    return out


def _equal(batch: np.ndarray, streamed: np.ndarray, rtol: float, atol: float) -> np.ndarray:
    if batch.dtype.kind in "fc" and streamed.dtype.kind in "fcbiu":
        ok = np.isclose(streamed.astype(np.float64), batch.astype(np.float64), rtol=rtol, atol=atol, equal_nan=True)
    else:
        ok = np.array([a == b for a, b in zip(batch.ravel(), streamed.ravel())], dtype=bool).reshape(batch.shape)
    return ok


def compare_streaming_to_batch(pipeline: Pipeline, frame, *, rtol: float = 1e-12, atol: float = 0.0,
                               names: Sequence[str] | None = None) -> list[str]:
    """Mismatches between ``pipeline.run(frame)`` and stepping it through ``frame``'s epochs after ``reset()``.

    ``pipeline`` is fitted; ``frame`` a record or columns with the step axis last. Every column the stages
    give (or ``names``) is compared at every epoch: floats within ``rtol``/``atol`` (NaN equals NaN), the
    others exactly. A ``run`` call in the middle of the stream must not change what follows. Returns
    human-readable mismatches (empty when all agree).
    """
    data = _frame(frame)
    batch = pipeline.run(data)
    steps = next(iter(data.values())).shape[-1]
    names = list(names) if names is not None else [n for n in pipeline.gives if n in batch]
    problems = [f"{n}: the result array is writeable" for n in names if batch[n].flags.writeable]
    pipeline.reset()
    streamed = []
    for k in range(steps):
        if k == steps // 2:
            pipeline.run(data)  # must leave the streaming state alone
        streamed.append(pipeline.step({n: v[..., k] for n, v in data.items()}))
    stacked = stack_steps(streamed, names)
    for name in names:
        b, s = np.asarray(batch[name]), stacked[name]
        if b.shape != s.shape:
            problems.append(f"{name}: streamed shape {s.shape} != batch {b.shape}")
            continue
        ok = _equal(b, s, rtol, atol)
        bad = np.flatnonzero(~ok.reshape(-1, steps).all(axis=0)) if ok.ndim > 1 else np.flatnonzero(~ok)
        if bad.size:
            problems.append(f"{name}: streaming != batch at {bad.size} epoch(s), first at epoch {bad[0]} "
                            f"(batch {b[..., bad[0]]!r}, streamed {s[..., bad[0]]!r})")
    return problems
