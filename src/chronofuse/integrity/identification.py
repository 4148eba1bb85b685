"""Identification mode: per-satellite clock biases of a static receiver and the faulty channel named.

Channel clock bias. For a receiver at a known position every satellite ``n`` gives its own estimate
``b_n(k)`` of the receiver clock bias (:mod:`chronofuse.gnss.observables` computes them,
:func:`chronofuse.io.rinex.channel_clock_biases` from RINEX files).

Common-mode removal. Every ``b_n`` holds the same receiver clock, so each channel is tested on its residual
against the median of the OTHER channels (:func:`chronofuse.integrity.common_mode.channel_residuals`; its
module docstring says why). Simulated channels for tests and experiments:
:func:`chronofuse.integrity.channel_sim.simulate_channel_biases`.

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

from chronofuse.gnss.observables import ChannelClockBiases
from chronofuse.integrity.channel_sim import SimulatedChannels, simulate_channel_biases  # noqa: F401 (re-exported)
from chronofuse.integrity.common_mode import (  # noqa: F401 (re-exported: callers import them from here)
    MIN_CLOCK_CHANNELS,
    aligned_channels,
    channel_residuals,
    common_clock_s,
)
from chronofuse.integrity.detector import DetectionResult, HodDetector
from chronofuse.validation import check_choice, check_scalar


@dataclass(frozen=True)
class IdentificationResult:
    """Per-channel detection over the common-mode-removed channel biases, every verdict causal.

    ``satellites`` (sats,); ``faulty`` the channels named by exclusion (see :func:`identify`), earliest
    first; ``first_blame_s`` (sats,) the epoch each was named at, ``first_alarm_s`` (sats,) each channel's
    first alarm in the final pass (NaN: none), seconds since the first epoch; ``results`` one
    :class:`DetectionResult` per channel (no statistic, no alarm while the channel trains);
    ``trained_at`` (sats,) the epoch whose data completed each channel's training (-1: never), its test
    starting at the next epoch; ``residual_s`` (epochs, sats) the biases minus ``common_s`` (epochs,);
    ``detectors`` the fitted copy used per channel; ``n_skipped_epochs`` as the input's.
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
    trained_at: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    blamed_at: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def untested(self) -> list[str]:
        """Channels never tested (too few valid epochs above the mask to learn their noise or fill a window)."""
        return [sat for sat, res in zip(self.satellites, self.results) if not (res.dof > 0).any()]

    @property
    def tested(self) -> np.ndarray:
        """Channels with a verdict per epoch, (epochs, sats) bool (trained and a window to test)."""
        return np.column_stack([r.dof > 0 for r in self.results]) if self.results else np.zeros((self.t_s.size, 0), bool)

    @property
    def faulty_mask(self) -> np.ndarray:
        """(epochs, sats) bool: channel named faulty at or before the epoch (latched; :func:`identify`)."""
        k = np.arange(self.t_s.size)[:, None]
        return (self.blamed_at[None, :] >= 0) & (k >= self.blamed_at[None, :])

    @property
    def alarms(self) -> list[dict]:
        """Every alarm as ``{"t": s since first epoch, "statistic": T, "channel": name}``, in time order."""
        out = []
        for sat, res in zip(self.satellites, self.results):
            for k in np.flatnonzero(res.alarm):
                out.append({"t": float(self.t_s[k]), "statistic": float(res.statistic[k]), "channel": sat,
                            "epoch": int(k)})
        return sorted(out, key=lambda a: (a["epoch"], a["channel"]))


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

    Causal: the verdict at epoch ``k`` uses epochs ``<= k`` only, so running on a longer
    record never changes an earlier verdict. The residuals are causal (:func:`channel_residuals`);
    when the noise model is incomplete each channel is fitted on its first ``train_epochs`` valid epochs
    (``noise="per_channel"``) or all channels on the first ``train_epochs`` epochs pooled (``"shared"``),
    and a channel is tested only from the epoch after its training stretch (before: no statistic, no
    alarm; the window is filled with the training residuals). A channel that cannot be fitted gets no
    test. ``remove_common=False`` tests the raw biases. ``detector`` is not changed.

    Naming is exclusion, as in RAIM fault detection and exclusion: at the first epoch with alarms the
    channel with the largest ``statistic / threshold`` is named and, from that epoch on (never before),
    taken out of every other channel's clock estimate; the channels are tested again from there. This
    repeats until no channel left in the clock estimate alarms, ``max_faults`` channels are named, or
    fewer than three channels would remain for the clock. A named channel stays named, and out of the
    others' clock, to the end of the record; whether it is still faulty (raised, or cleared once it is
    consistent with the others again) is :func:`chronofuse.integrity.channel_latch.latch_channels`. (A fault left in the clock estimate moves the other channels' medians by one
    rank: measured on the real 3040 station, a 100 ns step on G11 then made G20 alarm too.)
    """
    check_choice(noise, "noise", ("per_channel", "shared"))
    check_scalar(train_epochs, "train_epochs", min_val=3, integer=True)
    check_scalar(max_faults, "max_faults", min_val=0, integer=True)
    b = biases.bias_s
    sats = biases.satellites
    epochs = b.shape[0]
    template = copy.deepcopy(detector)
    template.interval_s = biases.interval_s
    exclude_from = np.full(len(sats), epochs, dtype=np.int64)
    blamed_at: dict[str, int] = {}
    fits: dict = {}
    seen = np.isfinite(b).any(axis=0)
    while True:
        if remove_common:
            resid, common = channel_residuals(b, exclude=exclude_from)
        else:
            resid, common = b.copy(), np.zeros(epochs)
        results, detectors, trained = _run_channels(template, resid, noise, train_epochs, fits)
        if max_faults == 0 or len(blamed_at) >= max_faults or not remove_common and blamed_at:
            break
        k, j = _strongest_alarm(results, exclude_from)
        if k < 0 or (seen & (exclude_from > k)).sum() - 1 < MIN_CLOCK_CHANNELS:
            break
        blamed_at[sats[j]] = k
        exclude_from[j] = k
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
        trained_at=trained,
        blamed_at=np.array([blamed_at.get(s, -1) for s in sats], dtype=np.int64),
    )


def _run_channels(template: HodDetector, resid: np.ndarray, noise: str, train_epochs: int, fits=None):
    """One fitted copy of ``template`` per column of ``resid`` (epochs, sats), its causal DetectionResult
    (no verdict up to the end of its training) and the epoch its training ended (-1: not fitted).
    ``fits`` caches the fits by training data (a stretch that exclusion did not change is not refitted)."""
    fits = {} if fits is None else fits
    epochs, sats = resid.shape
    shared, shared_end = None, -1
    if not _needs_fit(template):
        shared = copy.deepcopy(template).fit()
    elif noise == "shared":
        if epochs >= train_epochs:
            try:
                shared = copy.deepcopy(template).fit(resid[:train_epochs].T)
                shared_end = train_epochs - 1
            except ValueError:
                shared = None
    results, detectors = [], []
    trained = np.full(sats, -1, dtype=np.int64)
    for j in range(sats):
        col = resid[:, j]
        if shared is not None:
            det, end = copy.deepcopy(shared), shared_end
        elif noise == "shared" or not _needs_fit(template):
            det, end = None, -1
        else:
            det, end = _fit_channel(template, col, train_epochs, fits)
        if det is None:
            results.append(_no_test(col, template))
            detectors.append(copy.deepcopy(template))
            continue
        results.append(_after_training(det.run(col), end))
        detectors.append(det)
        trained[j] = end
    return results, detectors, trained


def _after_training(res: DetectionResult, end: int) -> DetectionResult:
    """``res`` with no verdict at epochs ``<= end`` (the training stretch: its model was fitted on them)."""
    if end < 0:
        return res
    stat, dof, thr = res.statistic.copy(), res.dof.copy(), res.threshold.copy()
    stat[: end + 1] = np.nan
    dof[: end + 1] = 0
    thr[: end + 1] = np.nan
    return DetectionResult.from_statistic(stat, dof, thr, np.where(res.skipped, np.nan, 0.0), res.window, res.pfa)


def _strongest_alarm(results: list[DetectionResult], exclude_from: np.ndarray) -> tuple[int, int]:
    """``(epoch, channel)`` of the largest ``statistic / threshold`` at the first epoch where a channel
    still in the clock estimate (``epoch < exclude_from``) alarms; ``(-1, -1)`` when none does."""
    ratio = np.column_stack([np.where(r.alarm, r.statistic / r.threshold, -np.inf) for r in results])
    ratio[np.arange(ratio.shape[0])[:, None] >= exclude_from[None, :]] = -np.inf
    epochs = np.flatnonzero(np.isfinite(ratio).any(axis=1))
    if epochs.size == 0:
        return -1, -1
    k = int(epochs[0])
    return k, int(np.argmax(ratio[k]))


def _fit_channel(template: HodDetector, col: np.ndarray, train_epochs: int, fits: dict) -> tuple[HodDetector | None, int]:
    """The detector fitted on the channel's first ``train_epochs`` valid epochs, and the last of them."""
    valid = np.flatnonzero(np.isfinite(col))
    if valid.size < max(train_epochs, 4):
        return None, -1
    end = int(valid[train_epochs - 1])
    stretch = col[valid[0] : end + 1]
    key = stretch.tobytes()
    if key not in fits:
        try:
            fits[key] = copy.deepcopy(template).fit(stretch)
        except ValueError:
            fits[key] = None
    det = fits[key]
    return (None, -1) if det is None else (copy.deepcopy(det), end)


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


__all__ = [
    "IdentificationResult",
    "SimulatedChannels",
    "aligned_channels",
    "channel_residuals",
    "common_clock_s",
    "identify",
    "simulate_channel_biases",
]
