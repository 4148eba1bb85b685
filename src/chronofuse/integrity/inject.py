"""Anomalies injected into clock biases for evaluation (SPEC 2.2 spoofing, SPEC 4 "must show").

Kinds, with ``tau = t - start_s`` (s) for ``t >= start_s`` and nothing before:

* ``"step"``  phase jump: ``+ size`` (s);
* ``"ramp"``  frequency step: ``+ size * tau`` (``size`` in s/s);
* ``"drag"``  slow quadratic drag-off (spoofing): ``+ size * tau^2 / 2`` (``size`` in s/s^2);
* ``"burst"`` noise burst: ``+ size * N(0, 1)`` white (``size`` in s) for ``duration_s``; needs a Generator.

``duration_s`` (None = to the end) limits any kind: after it a step stays, a ramp or drag keeps the offset
it reached (the receiver stays off), a burst stops.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.validation import check_array, check_choice, check_scalar

KINDS = ("step", "ramp", "drag", "burst")


@dataclass(frozen=True)
class Anomaly:
    """One anomaly: ``kind`` (step, ramp, drag, burst), ``start_s`` (s from the first epoch), ``size``
    (s, s/s, s/s^2 or s by kind), ``duration_s`` (None = to the end), ``channel`` (satellite column of an
    (epochs, sats) array, or None for a receiver clock bias along the last axis)."""

    kind: str
    start_s: float
    size: float
    duration_s: float | None = None
    channel: int | None = None

    def __post_init__(self):
        check_choice(self.kind, "kind", KINDS)
        check_scalar(self.start_s, "start_s", min_val=0.0)
        check_scalar(self.size, "size")
        if self.duration_s is not None:
            check_scalar(self.duration_s, "duration_s", min_val=0.0, include_min=False)
        if self.channel is not None:
            check_scalar(self.channel, "channel", min_val=0, integer=True)


def anomaly_profile(anomaly: Anomaly, steps: int, interval_s: float, rng: np.random.Generator | None = None) -> np.ndarray:
    """The additive clock-bias error (s) of ``anomaly`` over ``steps`` epochs ``k * interval_s``, shape (steps,).

    For a burst, ``rng`` draws the noise (one (steps,) draw).
    """
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    t = np.arange(steps) * float(interval_s)
    tau = t - anomaly.start_s
    active = tau >= 0.0
    end = np.inf if anomaly.duration_s is None else anomaly.duration_s
    tau_held = np.clip(tau, 0.0, end)
    if anomaly.kind == "step":
        return np.where(active, anomaly.size, 0.0)
    if anomaly.kind == "ramp":
        return np.where(active, anomaly.size * tau_held, 0.0)
    if anomaly.kind == "drag":
        return np.where(active, 0.5 * anomaly.size * tau_held**2, 0.0)
    if rng is None:
        raise ValueError("a noise burst needs rng (a numpy.random.Generator)")
    on = active & (tau < end)
    return np.where(on, anomaly.size * rng.standard_normal(steps), 0.0)


def inject(bias_s, anomaly: Anomaly, interval_s: float, rng: np.random.Generator | None = None) -> np.ndarray:
    """Return a copy of ``bias_s`` with ``anomaly`` added.

    ``bias_s``: receiver clock biases (s), shape (steps,) or (..., steps) with time along the last axis
    (``anomaly.channel`` None; every leading row gets the anomaly, bursts drawn independently per row), or
    satellite-channel biases of shape (epochs, sats) with time along axis 0 (``anomaly.channel`` = the
    column that gets it). NaN (missing) epochs stay NaN.
    """
    if anomaly.channel is None:
        x = check_array(bias_s, "bias_s", ndim=(1, 2, 3), allow_nan=True)
        out = x.copy()
        if anomaly.kind == "burst":
            rows = out.reshape(-1, out.shape[-1])
            for row in rows:
                row += anomaly_profile(anomaly, out.shape[-1], interval_s, rng)
            return rows.reshape(out.shape)
        return out + anomaly_profile(anomaly, out.shape[-1], interval_s, rng)
    x = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    if anomaly.channel >= x.shape[1]:
        raise ValueError(f"channel == {anomaly.channel}, must be < {x.shape[1]} (the number of satellite columns)")
    out = x.copy()
    out[:, anomaly.channel] += anomaly_profile(anomaly, x.shape[0], interval_s, rng)
    return out
