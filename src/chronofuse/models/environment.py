"""Where the receivers are: :class:`ReceiverEnvironment` (sky view, jamming, spoofing) and its presets.

An environment is a :class:`~chronofuse.models.receiver_model.ReceiverModel` (the noise, geometry and
outages the site gives the receiver) plus events in time: a jamming window (no fix, no 1PPS) and a
spoofer's drag-off of the receivers' time. :data:`ENVIRONMENTS` holds the four presets
(``open-sky``, ``urban-canyon``, ``jamming``, ``spoofing``); :func:`receiver_environment` picks one by
name. (The run's ``Scenario``, a TOML file, is :class:`chronofuse.experiments.scenario.Scenario`; it
names one of these environments.)

The drag-off of a spoofer that starts at ``t0`` is a polynomial in ``t - t0``::

    s(t) = spoof_rate_s_per_s (t - t0) + spoof_accel_s_per_s2 (t - t0)^2 / 2,   zero before t0,

so a ramp (constant false rate) and a quadratic (constant false acceleration) are one model; positive
values drag the receivers' time late.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.validation import InputError, check_choice, check_scalar

__all__ = ["ReceiverEnvironment", "ENVIRONMENTS", "receiver_environment"]


@dataclass(frozen=True)
class ReceiverEnvironment:
    """A named receiver environment: a :class:`ReceiverModel` plus jamming and spoofing events.

    Parameters
    ----------
    name : short name, e.g. ``"urban-canyon"``.
    model : the receivers' :class:`ReceiverModel`.
    description : one line for humans.
    jamming_start_s, jamming_duration_s : window ``[start, start + duration)`` (s since the run's
        start) with no fix and no 1PPS; ``None`` for none.
    spoof_start_s : start ``t0`` of the drag-off (s since the run's start); ``None`` for none.
    spoof_rate_s_per_s : false rate of the drag-off, s/s (the ramp term; see the module docstring).
    spoof_accel_s_per_s2 : false acceleration of the drag-off, s/s^2 (the quadratic term).
    affected_receivers : indices of the receivers that are jammed/spoofed; ``None`` means all.
    """

    name: str
    model: ReceiverModel
    description: str = ""
    jamming_start_s: float | None = None
    jamming_duration_s: float = 0.0
    spoof_start_s: float | None = None
    spoof_rate_s_per_s: float = 0.0
    spoof_accel_s_per_s2: float = 0.0
    affected_receivers: tuple[int, ...] | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name == {self.name!r}, must be a non-empty string")
        if not isinstance(self.model, ReceiverModel):
            raise TypeError(f"model == {self.model!r}, must be a ReceiverModel")
        if self.jamming_start_s is not None:
            check_scalar(self.jamming_start_s, "jamming_start_s", min_val=0.0)
        check_scalar(self.jamming_duration_s, "jamming_duration_s", min_val=0.0)
        if self.spoof_start_s is not None:
            check_scalar(self.spoof_start_s, "spoof_start_s", min_val=0.0)
        check_scalar(self.spoof_rate_s_per_s, "spoof_rate_s_per_s")
        check_scalar(self.spoof_accel_s_per_s2, "spoof_accel_s_per_s2")
        if self.affected_receivers is not None:
            for i in self.affected_receivers:
                check_scalar(i, "affected_receivers", min_val=0, integer=True)

    def spoof_offset_s(self, t_s: np.ndarray) -> np.ndarray:
        """Drag-off ``s(t)`` (s) at times ``t_s`` (s since the run's start), shape of ``t_s``."""
        t_s = np.asarray(t_s, dtype=np.float64)
        if self.spoof_start_s is None:
            return np.zeros_like(t_s)
        since = np.maximum(t_s - self.spoof_start_s, 0.0)
        offset = self.spoof_rate_s_per_s * since
        if self.spoof_accel_s_per_s2 != 0.0:
            offset = offset + 0.5 * self.spoof_accel_s_per_s2 * since**2
        return offset

    def jammed(self, t_s: np.ndarray) -> np.ndarray:
        """Boolean mask of the jamming window at times ``t_s``, shape of ``t_s``."""
        t_s = np.asarray(t_s, dtype=np.float64)
        if self.jamming_start_s is None:
            return np.zeros(t_s.shape, dtype=bool)
        return (t_s >= self.jamming_start_s) & (t_s < self.jamming_start_s + self.jamming_duration_s)

    def affected_mask(self, n_receivers: int) -> np.ndarray:
        """Boolean mask (n_receivers,) of the receivers the events reach; checks the indices fit."""
        check_scalar(n_receivers, "n_receivers", min_val=1, integer=True)
        affected = np.ones(int(n_receivers), dtype=bool)
        if self.affected_receivers is None:
            return affected
        if any(i >= n_receivers for i in self.affected_receivers):
            raise InputError(f"affected_receivers == {self.affected_receivers}, must be < {{n_receivers}} == {n_receivers}",
                             fields=("n_receivers",))
        affected[:] = False
        affected[list(self.affected_receivers)] = True
        return affected


# Only open sky is calibrated on data. The urban-canyon values are engineering assumptions (there is no
# urban 1PPS record in the project's data): noise that grows with the geometry, multipath several times
# the open-sky level and slower, NLOS outliers and short fix losses. The receiver oscillator
# (clock_* fields) is an assumed TCXO: ADEV 3e-10 at 1 s, offset within 0.5 ppm.
_OPEN_SKY = ReceiverModel()
_URBAN = dataclasses.replace(
    _OPEN_SKY,
    white_sigma_s=8e-9,
    multipath_sigma_s=20e-9,
    multipath_tau_s=60.0,
    outlier_prob=1e-3,
    outlier_sigma_s=100e-9,
    jump_prob=1e-4,
    jump_sigma_s=20e-9,
    outage_rate_hz=1.0 / 900.0,
    outage_mean_s=20.0,
    gdop_median=3.5,
    gdop_log_sigma=0.5,
    gdop_tau_s=120.0,
    n_sats_median=7.0,
    n_sats_spread=2.0,
)

ENVIRONMENTS: dict[str, ReceiverEnvironment] = {
    "open-sky": ReceiverEnvironment(
        "open-sky", _OPEN_SKY,
        "Static antenna with a clear view: GDOP about 1.5 (< 2), noise fitted to a GPS-vs-maser record."),
    "urban-canyon": ReceiverEnvironment(
        "urban-canyon", _URBAN,
        "Street canyon: GDOP > 5 about a quarter of the time, 20 ns multipath, NLOS outliers, fix losses."),
    "jamming": ReceiverEnvironment(
        "jamming", _OPEN_SKY,
        "Open sky, jammed from 600 s to 1200 s: no fix, no 1PPS.",
        jamming_start_s=600.0, jamming_duration_s=600.0),
    "spoofing": ReceiverEnvironment(
        "spoofing", _OPEN_SKY,
        "Open sky, spoofer drags time off at 2 ns/s from 600 s while the fix stays good.",
        spoof_start_s=600.0, spoof_rate_s_per_s=2e-9),
}  # fmt: skip


def receiver_environment(name: str) -> ReceiverEnvironment:
    """The preset environment called ``name`` (one of :data:`ENVIRONMENTS`)."""
    check_choice(name, "environment", ENVIRONMENTS)
    return ENVIRONMENTS[name]
