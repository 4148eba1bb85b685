"""Common-mode removal for identification: per-satellite clock biases with the receiver clock taken out.

Why (the choice made for :func:`chronofuse.integrity.identification.identify`). Every ``b_n`` holds the same
receiver clock; a clock jump or steering of the receiver would alarm every channel at once (measured in
simulation: a 1 ms jump alarms all 8 raw channels at the jump) and tells nothing about a satellite.
:func:`channel_residuals` aligns the channels (a per-arc offset against a median-of-increments clock, fixed at
the arc's first epoch: :func:`aligned_channels`) and gives channel ``n`` the residual against the median of
the OTHER channels (leave-one-out: a median over all channels is sometimes the channel itself, whose residual
is then flat and whose noise is underestimated: on station 0759, G11's residual stayed within 0.1 ns for 7
epochs that way). With at least three other channels one faulty channel cannot carry the others' clock.

Every value at epoch ``k`` uses epochs ``<= k`` only (causal), so a verdict never changes when later epochs
arrive.
"""

from __future__ import annotations

import numpy as np

from chronofuse.validation import check_array

__all__ = ["MIN_CLOCK_CHANNELS", "aligned_channels", "channel_residuals", "common_clock_s"]


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


def aligned_channels(bias_s: np.ndarray) -> np.ndarray:
    """Channel biases shifted onto one clock, causally: ``a_n(k) = b_n(k) - o_n``, shape (epochs, sats).

    ``o_n = b_n(k0) - c0(k0)`` is fixed at the first epoch ``k0`` of each unbroken arc of the channel
    (``c0`` from :func:`common_clock_s`, itself causal), so ``a_n(k)`` uses no epoch after ``k``: a verdict
    computed from it never changes when later epochs arrive (the former alignment, a median
    over the whole record, let a fault at 1800 s move the residuals at 60 s). A constant offset does not
    enter the second difference; the per-arc choice only sets where a rising channel sits among the
    others in the medians of :func:`channel_residuals`.
    """
    b = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    c0 = common_clock_s(b)
    dev = b - c0[:, None]
    valid = np.isfinite(dev)
    starts = valid & ~np.vstack([np.zeros((1, b.shape[1]), dtype=bool), valid[:-1]])
    rows = np.where(starts, np.arange(b.shape[0])[:, None], 0)
    rows = np.maximum.accumulate(rows, axis=0)
    offsets = dev[rows, np.arange(b.shape[1])[None, :]]
    return np.where(valid, b - offsets, np.nan)


#: Fewest other channels from which a channel's clock is estimated (one faulty channel among three
#: cannot carry their median).
MIN_CLOCK_CHANNELS = 3


def channel_residuals(bias_s: np.ndarray, exclude=None) -> tuple[np.ndarray, np.ndarray]:
    """Channel biases with the receiver clock removed, leave-one-out: ``(residual (epochs, sats), common (epochs,))``.

    1. align causally (:func:`aligned_channels`);
    2. channel ``n``'s clock follows the median over the OTHER channels: from epoch ``k-1`` to ``k`` it
       moves by ``median_S a_m(k) - median_S a_m(k-1)`` over the set ``S`` of other channels seen at both
       epochs and in the estimate at ``k``, so it stays continuous when a satellite rises, sets or is
       excluded (measured on station 3040: a median over whichever channels are there jumps by ns when
       one is excluded, and the step made another channel alarm); over a constant set it is the median
       of the set. A channel's residual ``a_n - c_-n`` never contains its own noise through the clock
       estimate (a median over all channels is at times the channel itself: its residual is then
       exactly flat), and one faulty channel moves the others' clocks by at most one rank of the median.
       Fewer than :data:`MIN_CLOCK_CHANNELS` others: NaN (no clock; the clock restarts at their median).

    ``common`` is the median of all aligned channels not excluded. ``exclude``: channels left out of the
    clock estimates: bool (sats,) (left out at every epoch) or int (sats,) (``exclude[n]`` = the epoch from
    which channel ``n`` is left out, as :func:`identify` names it; epochs before keep it, so the residuals
    there do not change). Excluded channels' own residuals are still computed. Every value at epoch
    ``k`` uses epochs ``<= k`` only.
    """
    b = check_array(bias_s, "bias_s", ndim=2, allow_nan=True)
    epochs, sats = b.shape
    if exclude is None:
        exclude_from = np.full(sats, epochs, dtype=np.int64)
    else:
        ex = np.asarray(exclude)
        if ex.shape != (sats,):
            raise ValueError(f"exclude has shape {ex.shape}, must be ({sats},)")
        exclude_from = np.where(ex, 0, epochs) if ex.dtype == bool else ex.astype(np.int64)
    aligned = aligned_channels(b)
    out = np.arange(epochs)[:, None] >= exclude_from[None, :]
    usable = np.where(out, np.nan, aligned)
    residual = aligned - _leave_one_out_clocks(aligned, out)
    common = np.full(epochs, np.nan)
    rows = np.isfinite(usable).any(axis=1)
    common[rows] = np.nanmedian(usable[rows], axis=1)
    return residual, common


def _leave_one_out_clocks(aligned: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Each channel's clock from the other channels, (epochs, sats) (:func:`channel_residuals`, step 2)."""
    epochs, sats = aligned.shape
    valid = np.isfinite(aligned)
    clocks = np.full(aligned.shape, np.nan)
    for n in range(sats):
        others = np.ones(sats, dtype=bool)
        others[n] = False
        level = np.nan
        for k in range(epochs):
            now = valid[k] & ~out[k] & others
            both = now & valid[k - 1] if k > 0 else np.zeros(sats, dtype=bool)
            if np.isfinite(level) and both.sum() >= MIN_CLOCK_CHANNELS:
                level += float(np.median(aligned[k, both]) - np.median(aligned[k - 1, both]))
            elif now.sum() >= MIN_CLOCK_CHANNELS:
                level = float(np.median(aligned[k, now]))
            else:
                level = np.nan
            clocks[k, n] = level
    return clocks
