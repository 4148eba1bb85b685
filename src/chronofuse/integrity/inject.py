"""Anomalies injected into clock biases for evaluation (steps, ramps, a spoofer's drag-off, noise bursts).

Kinds, with ``tau = t - start_s`` (s) for ``t >= start_s`` and nothing before; each kind's size is its own
field, named with its unit:

* ``"step"``  phase jump: ``+ offset_s`` (s);
* ``"ramp"``  frequency step: ``+ rate_s_per_s * tau`` (s/s);
* ``"drag"``  slow quadratic drag-off (spoofing): ``+ accel_s_per_s2 * tau^2 / 2`` (s/s^2);
* ``"burst"`` noise burst: ``+ sigma_s * N(0, 1)`` white (s) for ``duration_s``; needs a Generator.

``duration_s`` (None = to the end) limits any kind: after it a step stays, a ramp or drag keeps the offset
it reached (the receiver stays off), a burst stops.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass

import numpy as np

from chronofuse.validation import check_array, check_choice, check_scalar

KINDS = ("step", "ramp", "drag", "burst")

# The size field of each kind, and its unit.
SIZE_FIELDS = {"step": ("offset_s", "s"), "ramp": ("rate_s_per_s", "s/s"), "drag": ("accel_s_per_s2", "s/s^2"),
               "burst": ("sigma_s", "s")}


@dataclass(frozen=True)
class Anomaly:
    """One anomaly: ``kind`` (step, ramp, drag, burst), ``start_s`` (s from the first epoch), and by keyword
    the size of its kind, exactly one of ``offset_s`` (step, s), ``rate_s_per_s`` (ramp, s/s),
    ``accel_s_per_s2`` (drag, s/s^2) or ``sigma_s`` (burst, s); ``duration_s`` (None = to the end),
    ``channel`` (satellite column of an (epochs, sats) array, or None for a receiver clock bias along the
    last axis). Example: ``Anomaly("ramp", 250.0, rate_s_per_s=1e-10)``."""

    kind: str
    start_s: float
    _: KW_ONLY
    offset_s: float | None = None
    rate_s_per_s: float | None = None
    accel_s_per_s2: float | None = None
    sigma_s: float | None = None
    duration_s: float | None = None
    channel: int | None = None

    def __post_init__(self):
        check_choice(self.kind, "kind", KINDS)
        check_scalar(self.start_s, "start_s", min_val=0.0)
        own, unit = SIZE_FIELDS[self.kind]
        if getattr(self, own) is None:
            raise ValueError(f"{own} == None, must be given for a {self.kind} (its size, in {unit})")
        check_scalar(getattr(self, own), own, min_val=0.0 if self.kind == "burst" else None)
        for kind, (name, _unit) in SIZE_FIELDS.items():
            if name != own and getattr(self, name) is not None:
                raise ValueError(f"{name} == {getattr(self, name)}, must be None for a {self.kind} "
                                 f"({name} is the size of a {kind}; a {self.kind}'s is {own})")
        if self.duration_s is not None:
            check_scalar(self.duration_s, "duration_s", min_val=0.0, include_min=False)
        if self.channel is not None:
            check_scalar(self.channel, "channel", min_val=0, integer=True)

    @property
    def magnitude(self) -> float:
        """The size of this kind (the one of ``offset_s``, ``rate_s_per_s``, ``accel_s_per_s2``, ``sigma_s`` given)."""
        return float(getattr(self, SIZE_FIELDS[self.kind][0]))

    @property
    def unit(self) -> str:
        """The unit of :attr:`magnitude`: ``"s"``, ``"s/s"``, ``"s/s^2"`` or ``"s"``."""
        return SIZE_FIELDS[self.kind][1]


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
        return np.where(active, anomaly.offset_s, 0.0)
    if anomaly.kind == "ramp":
        return np.where(active, anomaly.rate_s_per_s * tau_held, 0.0)
    if anomaly.kind == "drag":
        return np.where(active, 0.5 * anomaly.accel_s_per_s2 * tau_held**2, 0.0)
    if rng is None:
        raise ValueError("a noise burst needs rng (a numpy.random.Generator)")
    on = active & (tau < end)
    return np.where(on, anomaly.sigma_s * rng.standard_normal(steps), 0.0)


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
