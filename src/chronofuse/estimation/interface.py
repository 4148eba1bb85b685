"""The one interface of every filter, servo, detector and sync algorithm (the filterpy and linuxptp lessons).

An estimator is built in four moves, scikit-learn style:

* ``__init__(**params)`` stores its arguments unchanged;
* ``fit(train=None, **inputs) -> self`` learns what it needs (attributes ending in ``_``) and resets;
* ``reset()`` forgets the streaming state;
* ``step(z, **inputs) -> step output`` takes one epoch of one trial (``z`` a float, or shape (m,)) and
  returns a frozen dataclass;
* ``run(Z, **inputs) -> result`` takes a whole batch, ``Z`` of shape (trials, steps, ...) (an estimator
  may also take one trial without its trial axis), never mutates the estimator (its streaming state
  included) and returns a frozen :class:`FrozenResult` whose arrays are read-only and have ``Z``'s
  leading (trials, steps) axes.

``inputs`` are extra per-epoch series beside the measurement (a reference clock's reading, a control
input); an estimator names those it needs in the class attribute ``inputs`` (a tuple of keyword names),
and :func:`pick_inputs` hands it exactly those, so one caller drives every estimator without asking which
one it is. Streaming equals batch: every field that a step output and the result share by name must
agree, ``result.<field>[trial, step] == step(...).<field>``; :func:`compare_streaming_to_batch` checks it
for any estimator and is what each family's tests call.

``step`` and ``run`` call one pure functional core (for linear Gaussian models
:mod:`chronofuse.estimation.kalman`), so the two paths cannot drift apart.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Estimator(Protocol):
    """What every estimator offers (module docstring). ``inputs`` names the extra per-epoch inputs it needs."""

    inputs: ClassVar[tuple[str, ...]]

    def fit(self, train=None, **inputs) -> Estimator:
        """Learn from ``train`` (anomaly-free or calibration data; None if all parameters are given); reset; self."""

    def reset(self) -> None:
        """Forget the streaming state."""

    def step(self, z, **inputs) -> Any:
        """One epoch of one trial (NaN or None = missing); a frozen dataclass whose fields match the result's."""

    def run(self, Z, **inputs) -> FrozenResult:
        """A batch (trials, steps, ...) without mutating the estimator; a frozen result with read-only arrays."""


def readonly(a) -> np.ndarray:
    """A read-only view of ``a`` (no copy); the caller's own array keeps its flags."""
    view = np.asarray(a).view()
    view.flags.writeable = False
    return view


@dataclasses.dataclass(frozen=True)
class FrozenResult:
    """Base of every ``run`` result (and of array-holding step outputs): a frozen dataclass whose ndarray
    fields are made read-only views, so no caller can write into an estimator's state through them.

    Subclasses are ``@dataclass(frozen=True)`` too and simply declare their fields.
    """

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                object.__setattr__(self, f.name, readonly(value))


def pick_inputs(estimator, **available) -> dict:
    """The extra inputs ``estimator`` declares (its ``inputs`` attribute), taken from ``available``.

    Raises ``ValueError`` naming an input the estimator needs that ``available`` lacks.
    """
    needed = tuple(getattr(estimator, "inputs", ()))
    missing = [name for name in needed if name not in available]
    if missing:
        raise ValueError(f"{type(estimator).__name__} needs the input(s) {missing}; given {sorted(available)}")
    return {name: available[name] for name in needed}


def _same(batch: np.ndarray, streamed: np.ndarray, rtol: float, atol: float) -> np.ndarray:
    """Per-step agreement of two (steps, ...) arrays: floats within tolerance (NaN equals NaN), others exact."""
    if batch.dtype.kind in "fc" or streamed.dtype.kind in "fc":
        ok = np.isclose(streamed.astype(np.float64), batch.astype(np.float64), rtol=rtol, atol=atol, equal_nan=True)
    else:
        ok = streamed == batch
    return ok.reshape(ok.shape[0], -1).all(axis=1)


def compare_streaming_to_batch(estimator, Z, *, rtol: float = 1e-10, atol: float = 0.0, **inputs) -> list[str]:
    """Mismatches between ``estimator.run(Z, **inputs)`` and stepping through ``Z`` trial by trial.

    ``Z`` has shape (trials, steps, ...) and each of ``inputs`` (trials, steps); ``estimator`` is fitted.
    For every trial, ``reset()`` then ``step`` through its epochs; every ndarray field that the step
    outputs and the batch result share by name is compared at every (trial, step), float fields within
    ``rtol``/``atol`` (NaN equals NaN), the others exactly. Trial 0 is streamed with a ``run`` call in the
    middle, which must not change what follows (``run`` never mutates). Every ndarray of the result must
    be read-only. Returns human-readable mismatches (empty when all agree); raises ``ValueError`` when the
    step output and the result share no field or the result lacks the (trials, steps) axes.
    """
    Z = np.asarray(Z)
    if Z.ndim < 2:
        raise ValueError(f"Z has shape {Z.shape}, must have a trial and a step axis (trials, steps, ...)")
    trials, steps = Z.shape[:2]
    result = estimator.run(Z, **inputs)
    arrays = {f.name: getattr(result, f.name) for f in dataclasses.fields(result)
              if isinstance(getattr(result, f.name), np.ndarray)}
    problems = [f"{name}: the result array is writeable" for name, a in arrays.items() if a.flags.writeable]
    for name, a in arrays.items():
        if a.shape[:2] != (trials, steps):
            raise ValueError(f"result field {name} has shape {a.shape}, must start with (trials, steps) = "
                             f"{Z.shape[:2]}")
    shared: list[str] = []
    for i in range(trials):
        estimator.reset()
        outs = []
        for k in range(steps):
            if i == 0 and k == steps // 2:
                estimator.run(Z, **inputs)  # must leave the streaming state alone
            outs.append(estimator.step(Z[i, k], **{n: np.asarray(v)[i, k] for n, v in inputs.items()}))
        if i == 0:
            step_fields = {f.name for f in dataclasses.fields(outs[0])}
            shared = [name for name in arrays if name in step_fields]
            if not shared:
                raise ValueError(f"{type(estimator).__name__}: its step output and run result share no field")
        for name in shared:
            streamed = np.array([np.asarray(getattr(o, name)) for o in outs])
            if streamed.shape != arrays[name][i].shape:
                problems.append(f"{name}: trial {i} streamed shape {streamed.shape} != batch {arrays[name][i].shape}")
                continue
            bad = np.flatnonzero(~_same(arrays[name][i], streamed, rtol, atol))
            if bad.size:
                problems.append(f"{name}: trial {i} streaming != batch at {bad.size} step(s), first at step {bad[0]}")
    return problems


def nan_if_none(value) -> float:
    """A scalar measurement as float, ``None`` read as NaN (a missing epoch)."""
    return math.nan if value is None else float(value)
