"""Simulated per-satellite clock biases of a static receiver, for identification.

A common receiver clock (offset + drift, optionally a millisecond-style jump as receivers that steer
their clock make) plus white pseudorange noise per channel, and an anomaly
(:mod:`chronofuse.integrity.inject`) on one channel: the input
:func:`chronofuse.integrity.identification.identify` sees, with the truth beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.observables import ChannelClockBiases, channel_clock_biases_from_arrays
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.validation import check_scalar

__all__ = ["SimulatedChannels", "simulate_channel_biases"]


@dataclass(frozen=True)
class SimulatedChannels:
    """A simulated static receiver: ``biases`` (what identification sees), ``receiver_clock_s`` (epochs,)
    the common clock truth, ``faulty_channel`` (column index, or None) and the ``anomaly`` injected."""

    biases: ChannelClockBiases
    receiver_clock_s: np.ndarray
    faulty_channel: int | None
    anomaly: Anomaly | None


def simulate_channel_biases(
    *,
    n_satellites: int,
    steps: int,
    interval_s: float,
    sigma_rho_m,
    rng: np.random.Generator,
    anomaly: Anomaly | None = None,
    clock_drift_s_per_s: float = 1e-8,
    clock_jump_s: float = 0.0,
    clock_jump_at: int | None = None,
) -> SimulatedChannels:
    """Per-channel clock biases of a static receiver: a common receiver clock (offset + drift, optionally a
    millisecond-style jump at epoch ``clock_jump_at``, as receivers that steer their clock do) plus white
    pseudorange noise ``sigma_rho_m / c`` per channel (scalar or (n_satellites,)), and ``anomaly`` (with
    its ``channel``) on one channel. Shapes: (steps, n_satellites)."""
    check_scalar(n_satellites, "n_satellites", min_val=1, integer=True)
    check_scalar(steps, "steps", min_val=3, integer=True)
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    sigma = np.broadcast_to(np.asarray(sigma_rho_m, dtype=np.float64), (n_satellites,))
    if np.any(sigma < 0) or not np.all(np.isfinite(sigma)):
        raise ValueError(f"sigma_rho_m == {sigma_rho_m}, must be finite and >= 0")
    t = np.arange(steps) * float(interval_s)
    clock = 1e-4 + clock_drift_s_per_s * t
    if clock_jump_at is not None:
        clock = clock + np.where(np.arange(steps) >= clock_jump_at, clock_jump_s, 0.0)
    noise = rng.standard_normal((steps, n_satellites)) * (sigma / SPEED_OF_LIGHT_M_PER_S)
    bias = clock[:, None] + noise
    channel = None
    if anomaly is not None:
        if anomaly.channel is None:
            raise ValueError("anomaly.channel is None: identification needs the anomaly on one satellite channel")
        bias = inject(bias, anomaly, interval_s, rng)
        channel = int(anomaly.channel)
    return SimulatedChannels(
        biases=channel_clock_biases_from_arrays(bias, interval_s),
        receiver_clock_s=clock,
        faulty_channel=channel,
        anomaly=anomaly,
    )
