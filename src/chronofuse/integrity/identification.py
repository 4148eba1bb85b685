"""Identification mode (SPEC 4): per-satellite clock biases of a static receiver and the faulty channel named.

Channel clock bias. For a receiver at a known position every satellite ``n`` gives its own estimate
``b_n(k)`` of the receiver clock bias (SPEC 4; :mod:`chronofuse.gnss.observables` computes them,
:func:`chronofuse.io.rinex.channel_clock_biases` from RINEX files).

Common-mode removal (the choice made here). Every ``b_n`` holds the same receiver clock; a clock jump or
steering of the receiver would alarm every channel at once (measured in simulation: a 1 ms jump alarms
all 8 raw channels at the jump) and tells nothing about a satellite. :func:`channel_residuals` aligns the
channels (per-channel median offset against a median-of-increments clock, continuous when satellites rise
or set) and gives channel ``n`` the residual against the median of the OTHER channels (leave-one-out: a
median over all channels is sometimes the channel itself, whose residual is then flat and whose noise is
underestimated: on station 0759, G11's residual stayed within 0.1 ns for 7 epochs that way). With at least
three other channels one faulty channel cannot carry the others' clock.

Naming (:func:`identify`) is exclusion, as in RAIM: at the first alarm epoch the channel with the largest
``statistic / threshold`` is named and removed from every other channel's clock, and all are tested again.

Noise model. A detector whose ``h0``, ``hm2`` and ``sigma_rho_m`` are all given is used as it is on every
channel. Otherwise the missing parameters are learnt from the first ``train_epochs`` epochs, either
``"per_channel"`` (default: each channel on its own first valid epochs; low-elevation channels are
several times noisier than high ones) or ``"shared"`` (one model on all channels pooled). Measured on the
two real Trimble 5700 stations (15 deg mask, window 10, P_fa 1e-3, 100 ns step on each fully observed
channel): per-channel named the faulty satellite alone in 9 of 10 cases and with it in 10 of 10; shared
named it alone in 6 of 10 (at 3040 it also named G07, before the fault). In simulation (8 channels,
1 m noise, 200 training epochs, 20 seeds) the per-channel empirical false-alarm rate was 1.03e-3 for
P_fa = 1e-3 (shared: 0.13e-3).

Elevation mask 15 deg by default: with 10 deg the clean real data named satellites between 10 and 15 deg
(G08 setting, G04 rising: multipath and growing noise), with 15 deg none.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.observables import ChannelClockBiases, channel_clock_biases_from_arrays
from chronofuse.integrity.detector import DetectionResult, HodDetector
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.validation import check_array, check_choice, check_scalar


# ---------------------------------------------------------------------------------------------------------
# Identification
# ---------------------------------------------------------------------------------------------------------


def common_clock_s(bias_s: np.ndarray) -> np.ndarray:
    """Common receiver clock (s), shape (epochs,): cumulative cross-channel median of the increments
    ``b_n(k) - b_n(k-1)`` over channels seen at both epochs (continuous when satellites rise or set).
    Starts at the median of the first epoch; after an epoch with no channel it restarts at the median of
    the biases. Used to align the channels (:func:`channel_residuals`)."""
    b = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    out = np.full(b.shape[0], np.nan)
    level = np.nan
    prev_row = np.full(b.shape[1], np.nan)
    for k, row in enumerate(b):
        inc = row - prev_row
        inc = inc[np.isfinite(inc)]
        if inc.size:
            level = level + float(np.median(inc))
        elif np.isfinite(row).any():
            level = float(np.median(row[np.isfinite(row)]))
        else:
            level = np.nan
        out[k] = level
        prev_row = row
    return out


def channel_residuals(bias_s: np.ndarray, exclude=None) -> tuple[np.ndarray, np.ndarray]:
    """Channel biases with the receiver clock removed, leave-one-out: ``(residual (epochs, sats), common (epochs,))``.

    1. align: ``o_n = median_k(b_n(k) - c0(k))`` over all the channel's epochs, with ``c0`` from
       :func:`common_clock_s`, ``a_n = b_n - o_n`` (aligning on the training stretch only was tried and
       measured worse on the real stations: the satellites' residual errors drift by ns over an hour, and
       the channels then change rank in the medians);
    2. channel ``n``'s clock is the median over the OTHER channels, ``c_-n(k) = median_{m != n} a_m(k)``,
       so a channel's residual ``a_n - c_-n`` never contains its own noise through the clock estimate
       (a median over all channels is at times the channel itself: its residual is then exactly flat
       and its noise is underestimated), and one faulty channel moves the other channels' clocks by at
       most one rank of the median.
    ``common`` is the median of all aligned channels. ``exclude`` (bool, (sats,)): channels left out of
    every clock estimate (channels already named faulty); their residuals are still computed.
    """
    b = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    out = np.zeros(b.shape[1], dtype=bool) if exclude is None else np.asarray(exclude, dtype=bool)
    if out.shape != (b.shape[1],):
        raise ValueError(f"exclude has shape {out.shape}, must be ({b.shape[1]},)")
    c0 = common_clock_s(b[:, ~out])
    dev = b - c0[:, None]
    seen = np.isfinite(dev).any(axis=0)
    offsets = np.zeros(b.shape[1])
    offsets[seen] = np.nanmedian(dev[:, seen], axis=0)
    aligned = b - offsets
    residual = np.full(b.shape, np.nan)
    for n in range(b.shape[1]):
        others = aligned[:, (np.arange(b.shape[1]) != n) & ~out]
        have = np.isfinite(others).any(axis=1)
        clock = np.full(b.shape[0], np.nan)
        clock[have] = np.nanmedian(others[have], axis=1)
        residual[:, n] = aligned[:, n] - clock
    common = np.full(b.shape[0], np.nan)
    kept = aligned[:, ~out]
    rows = np.isfinite(kept).any(axis=1)
    common[rows] = np.nanmedian(kept[rows], axis=1)
    return residual, common


@dataclass(frozen=True)
class IdentificationResult:
    """Per-channel detection over the common-mode-removed channel biases.

    ``satellites`` (sats,); ``faulty`` the channels named by exclusion (see :func:`identify`), earliest
    first; ``first_blame_s`` (sats,) the epoch each was named at, ``first_alarm_s`` (sats,) each channel's
    first alarm in the final pass (NaN: none), seconds since the first epoch; ``results`` one
    :class:`DetectionResult` per channel; ``residual_s`` (epochs, sats) the biases minus ``common_s``
    (epochs,); ``detectors`` the fitted copy used per channel; ``n_skipped_epochs`` as the input's.
    """

    satellites: list[str]
    faulty: list[str]
    first_blame_s: np.ndarray
    first_alarm_s: np.ndarray
    results: list[DetectionResult]
    residual_s: np.ndarray
    common_s: np.ndarray
    t_s: np.ndarray
    n_skipped_epochs: int
    detectors: list[HodDetector] = field(default_factory=list)

    @property
    def untested(self) -> list[str]:
        """Channels never tested (too few valid epochs above the mask to learn their noise or fill a window)."""
        return [sat for sat, res in zip(self.satellites, self.results) if not (res.dof > 0).any()]

    @property
    def alarms(self) -> list[dict]:
        """Every alarm as ``{"t": s since first epoch, "statistic": T, "channel": name}``, in time order."""
        out = []
        for sat, res in zip(self.satellites, self.results):
            for k in np.flatnonzero(res.alarm):
                out.append({"t": float(self.t_s[k]), "statistic": float(res.statistic[k]), "channel": sat})
        return sorted(out, key=lambda a: (a["t"], a["channel"]))


def _needs_fit(detector: HodDetector) -> bool:
    return any(getattr(detector, name) is None for name in ("h0", "hm2", "sigma_rho_m"))


def identify(
    biases: ChannelClockBiases,
    detector: HodDetector,
    *,
    noise: str = "per_channel",
    train_epochs: int = 40,
    remove_common: bool = True,
    max_faults: int = 2,
) -> IdentificationResult:
    """Run a fresh copy of ``detector`` on each channel's common-mode-removed bias and name the faulty ones.

    ``detector`` is not changed. When its noise model is incomplete, it is fitted on the first
    ``train_epochs`` epochs: per channel (``noise="per_channel"``, each channel's first ``train_epochs``
    valid epochs) or on all channels pooled (``"shared"``). A channel that cannot be fitted (too few
    epochs) gets no test (all-NaN statistic, no alarm). ``remove_common=False`` tests the raw biases.

    Naming is exclusion, as in RAIM fault detection and exclusion: at the first epoch with alarms the
    channel with the largest ``statistic / threshold`` is named and taken out of every other channel's
    clock estimate (:func:`channel_residuals` ``exclude``), and all channels are tested again; this repeats
    until no channel left in the clock estimate alarms, ``max_faults`` channels are named, or fewer than
    three channels would remain for the clock. (A fault left in the clock estimate moves the other
    channels' medians by one rank: measured on the real 3040 station, a 100 ns step on G11 then made G20
    alarm too, for many epochs; after exclusion it does not.)
    """
    check_choice(noise, "noise", ("per_channel", "shared"))
    check_scalar(train_epochs, "train_epochs", min_val=3, integer=True)
    check_scalar(max_faults, "max_faults", min_val=0, integer=True)
    b = biases.bias_s
    sats = biases.satellites
    template = copy.deepcopy(detector)
    template.interval_s = biases.interval_s
    excluded = np.zeros(b.shape[1], dtype=bool)
    blamed_at: dict[str, int] = {}
    while True:
        if remove_common:
            resid, common = channel_residuals(b, exclude=excluded)
        else:
            resid, common = b.copy(), np.zeros(b.shape[0])
        results, detectors = _run_channels(template, resid, noise, train_epochs)
        k, j = _strongest_alarm(results, ~excluded)
        if k < 0 or max_faults == 0:
            break
        blamed_at[sats[j]] = k
        excluded[j] = True
        seen = np.isfinite(b).any(axis=0)
        if not remove_common or len(blamed_at) >= max_faults or (seen & ~excluded).sum() < 3:
            if remove_common and (seen & ~excluded).sum() >= 3:
                resid, common = channel_residuals(b, exclude=excluded)
                results, detectors = _run_channels(template, resid, noise, train_epochs)
            break
    first = np.array([biases.t_s[r.first_alarm()] if r.first_alarm() >= 0 else np.nan for r in results])
    return IdentificationResult(
        satellites=list(sats),
        faulty=sorted(blamed_at, key=blamed_at.get),
        first_blame_s=np.array([biases.t_s[blamed_at[s]] if s in blamed_at else np.nan for s in sats]),
        first_alarm_s=first,
        results=results,
        residual_s=resid,
        common_s=common,
        t_s=biases.t_s,
        n_skipped_epochs=biases.n_skipped_epochs,
        detectors=detectors,
    )


def _run_channels(template: HodDetector, resid: np.ndarray, noise: str, train_epochs: int):
    """One fitted copy of ``template`` per column of ``resid`` (epochs, sats) and its DetectionResult."""
    shared = None
    if not _needs_fit(template):
        shared = copy.deepcopy(template).fit()
    elif noise == "shared":
        shared = copy.deepcopy(template).fit(resid[:train_epochs].T)
    results, detectors = [], []
    for j in range(resid.shape[1]):
        col = resid[:, j]
        det = copy.deepcopy(shared) if shared is not None else _fit_channel(template, col, train_epochs)
        if det is None:
            results.append(_no_test(col, template))
            detectors.append(copy.deepcopy(template))
            continue
        results.append(det.run(col))
        detectors.append(det)
    return results, detectors


def _strongest_alarm(results: list[DetectionResult], candidates: np.ndarray) -> tuple[int, int]:
    """``(epoch, channel)`` of the largest ``statistic / threshold`` at the first epoch where a candidate
    channel alarms; ``(-1, -1)`` when none does."""
    ratio = np.column_stack([np.where(r.alarm, r.statistic / r.threshold, -np.inf) for r in results])
    ratio[:, ~candidates] = -np.inf
    epochs = np.flatnonzero(np.isfinite(ratio).any(axis=1))
    if epochs.size == 0:
        return -1, -1
    k = int(epochs[0])
    return k, int(np.argmax(ratio[k]))


def _fit_channel(template: HodDetector, col: np.ndarray, train_epochs: int) -> HodDetector | None:
    valid = np.flatnonzero(np.isfinite(col))
    if valid.size < max(train_epochs, 4):
        return None
    stretch = col[valid[0] : valid[train_epochs - 1] + 1]
    try:
        return copy.deepcopy(template).fit(stretch)
    except ValueError:
        return None


def _no_test(col: np.ndarray, template: HodDetector) -> DetectionResult:
    skipped = np.isnan(col)
    return DetectionResult(
        statistic=np.full(col.shape, np.nan),
        alarm=np.zeros(col.shape, dtype=bool),
        dof=np.zeros(col.shape, dtype=np.int64),
        threshold=np.full(col.shape, np.nan),
        skipped=skipped,
        n_skipped=int(skipped.sum()),
        window=int(template.window),
        pfa=float(template.pfa),
    )


# ---------------------------------------------------------------------------------------------------------
# Simulation
# ---------------------------------------------------------------------------------------------------------


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


__all__ = [
    "IdentificationResult",
    "SimulatedChannels",
    "channel_residuals",
    "common_clock_s",
    "identify",
    "simulate_channel_biases",
]
