"""The receiver clock a station's channels share, and each channel's residual against the others, one epoch
at a time.

Each channel ``n`` of a code gives its own estimate ``b_n(k)`` of the receiver clock bias at the known
position (:func:`chronofuse.gnss.observables.channel_biases`). The common clock is removed from each channel
in three steps (the reasons are in :mod:`chronofuse.integrity.common_mode`, whose whole-record functions this
module computes epoch by epoch):

1. **Common clock** ``c0(k) = c0(k-1) + median_S (b(k) - b(k-1))`` over the channels ``S`` seen at both epochs
   and not excluded: continuous when satellites rise and set, a named satellite does not move it. Restarts at
   the median of the biases after an epoch without any increment. It is the receiver clock of the code
   (identification's receiver-clock test watches it).
2. **Alignment**: ``a_n(k) = b_n(k) - o_n``, ``o_n = b_n(k0) - c0(k0)`` fixed at the first epoch ``k0`` of each
   unbroken arc of the channel.
3. **Leave-one-out clock**: channel ``n``'s clock moves from ``k-1`` to ``k`` by ``median_S a(k) - median_S
   a(k-1)`` over the other channels ``S`` seen at both epochs and not excluded (fewer than
   :data:`MIN_CLOCK_CHANNELS`: it restarts at the median of the others at ``k``, or is NaN); the residual is
   ``a_n(k) - clock_n(k)``. A restart of the clock breaks the channel's difference chain (``restarted``).

Exclusion (``excluded``): the satellites named faulty are left out of every clock from the epoch they are
named; their own residuals are still given (against a clean clock).

:meth:`CodeClock.step` computes one epoch from the state of the previous one and is pure apart from
:meth:`CodeClock.commit`: identification calls ``step`` again at the same epoch after each exclusion, then
commits the last. The leave-one-out medians of all channels come from one sort
(:func:`leave_one_out_medians`), the median of ``M - 1`` values read off the sorted ``M`` by rank.

A day of a station is 2880 epochs of some fifteen codes, each stepped once per pass: numpy's overhead on
arrays of a dozen channels made the step 0.8 ms, 34 of the 52 s of a day's identification. So the step runs
compiled (:func:`clock_step_kernel`, the same arithmetic loop by loop); ``CodeClock(fast=False)`` runs the
readable numpy twin, and the tests hold the two equal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from chronofuse.integrity.common_mode import MIN_CLOCK_CHANNELS

__all__ = ["CodeClock", "ClockEpoch", "leave_one_out_medians", "leave_one_out_medians_rows", "clock_step_kernel",
           "MIN_CLOCK_CHANNELS"]


def leave_one_out_medians(values: np.ndarray, member: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each channel, the median of ``values`` over the members other than itself, and how many those
    are: ``(medians (C,), counts (C,))``; NaN where no member is left. ``values`` (C,), ``member`` (C,) bool."""
    values = np.asarray(values, dtype=np.float64)
    member = np.asarray(member, dtype=bool)
    c = values.size
    idx = np.flatnonzero(member)
    m = idx.size
    counts = np.where(member, m - 1, m)
    out = np.full(c, np.nan)
    if m == 0:
        return out, counts
    order = np.argsort(values[idx], kind="stable")
    s = values[idx][order]
    rank = np.empty(m, dtype=np.intp)
    rank[order] = np.arange(m)

    def median_of(n: int) -> float:
        return float(s[(n - 1) // 2] + s[n // 2]) / 2.0

    full = median_of(m)
    out[~member] = full
    if m >= 2:
        k = m - 1  # values left after one is removed
        r = rank
        lo_pos, hi_pos = (k - 1) // 2, k // 2  # positions of the middle values among the k left
        lo = np.where(lo_pos < r, s[lo_pos], s[np.minimum(lo_pos + 1, m - 1)])
        hi = np.where(hi_pos < r, s[hi_pos], s[np.minimum(hi_pos + 1, m - 1)])
        out[idx] = 0.5 * (lo + hi)
    return out, counts


def leave_one_out_medians_rows(values: np.ndarray, member: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`leave_one_out_medians` of each row of ``values`` and ``member`` (R, C) at once, from one sort of
    the rows (members first): ``(medians (R, C), counts (R, C))``."""
    values = np.asarray(values, dtype=np.float64)
    member = np.asarray(member, dtype=bool)
    r, c = values.shape
    m = member.sum(axis=1)  # (R,)
    counts = np.where(member, m[:, None] - 1, m[:, None])
    keyed = np.where(member, values, np.nan)
    order = np.lexsort((keyed, ~member), axis=1)  # members first, each row's in ascending order (NaN last)
    s = np.take_along_axis(keyed, order, axis=1)
    rank = np.empty_like(order)
    np.put_along_axis(rank, order, np.broadcast_to(np.arange(c), (r, c)), axis=1)
    rows = np.arange(r)

    def at(pos):
        return s[rows[:, None] if np.ndim(pos) == 2 else rows, np.clip(pos, 0, c - 1)]

    full = 0.5 * (at((m - 1) // 2) + at(m // 2))
    k = m - 1
    lo_pos, hi_pos = ((k - 1) // 2)[:, None], (k // 2)[:, None]
    top = np.maximum(m - 1, 0)[:, None]
    lo = np.where(lo_pos < rank, at(np.broadcast_to(lo_pos, (r, c))), at(np.minimum(lo_pos + 1, top)))
    hi = np.where(hi_pos < rank, at(np.broadcast_to(hi_pos, (r, c))), at(np.minimum(hi_pos + 1, top)))
    out = np.where(member, 0.5 * (lo + hi), full[:, None])
    out = np.where((m[:, None] == 0) | (member & (m[:, None] < 2)), np.nan, out)
    return out, counts


@numba.njit(cache=True)
def _median(x):
    s = np.sort(x)
    n = s.size
    return (s[(n - 1) // 2] + s[n // 2]) / 2.0


@numba.njit(cache=True)
def _leave_one_out(values, member, out, counts):
    """:func:`leave_one_out_medians` into ``out`` and ``counts`` (compiled)."""
    c = values.size
    m = 0
    picked = np.empty(c)
    where = np.empty(c, np.int64)
    for i in range(c):
        if member[i]:
            picked[m] = values[i]
            where[m] = i
            m += 1
    order = np.argsort(picked[:m], kind="mergesort")
    s = picked[:m][order]
    rank = np.zeros(c, np.int64)
    for r in range(m):
        rank[where[order[r]]] = r
    full = 0.5 * (s[(m - 1) // 2] + s[m // 2]) if m > 0 else np.nan
    k = m - 1
    lo_pos, hi_pos = (k - 1) // 2, k // 2
    for i in range(c):
        if not member[i]:
            out[i] = full
            counts[i] = m
        elif m < 2:
            out[i] = np.nan
            counts[i] = m - 1
        else:
            lo = s[lo_pos] if lo_pos < rank[i] else s[min(lo_pos + 1, m - 1)]
            hi = s[hi_pos] if hi_pos < rank[i] else s[min(hi_pos + 1, m - 1)]
            out[i] = 0.5 * (lo + hi)
            counts[i] = m - 1


@numba.njit(cache=True)
def clock_step_kernel(b, excluded, prev_b, c0, offset, prev_a, loo, min_channels):
    """:meth:`CodeClock.step` compiled: ``(residual, restarted, c0, arc_start, biases, offset, aligned,
    leave-one-out clocks)``, the last four the state to commit."""
    c = b.size
    valid = np.empty(c, np.bool_)
    for i in range(c):
        valid[i] = math.isfinite(b[i])
    # 1. common clock
    inc = np.empty(c)
    n_inc = 0
    for i in range(c):
        if valid[i] and math.isfinite(prev_b[i]) and not excluded[i]:
            inc[n_inc] = b[i] - prev_b[i]
            n_inc += 1
    if math.isfinite(c0) and n_inc > 0:
        c0 = c0 + _median(inc[:n_inc])
    else:
        pool = np.empty(c)
        n_pool = 0
        for i in range(c):
            if valid[i] and not excluded[i]:
                pool[n_pool] = b[i]
                n_pool += 1
        if n_pool == 0:
            for i in range(c):
                if valid[i]:
                    pool[n_pool] = b[i]
                    n_pool += 1
        c0 = _median(pool[:n_pool]) if n_pool > 0 else np.nan
    # 2. alignment
    arc_start = np.empty(c, np.bool_)
    new_offset = np.empty(c)
    a = np.empty(c)
    biases = np.empty(c)
    pair = np.empty(c, np.bool_)
    now_set = np.empty(c, np.bool_)
    for i in range(c):
        arc_start[i] = valid[i] and not math.isfinite(prev_b[i])
        o = b[i] - c0 if arc_start[i] else offset[i]
        new_offset[i] = o if valid[i] else np.nan
        a[i] = b[i] - new_offset[i] if valid[i] else np.nan
        biases[i] = b[i] if valid[i] else np.nan
        pair[i] = valid[i] and math.isfinite(prev_a[i]) and not excluded[i]
        now_set[i] = valid[i] and not excluded[i]
    # 3. leave-one-out clocks
    med_now, med_prev, level = np.empty(c), np.empty(c), np.empty(c)
    n_pair, n_prev, n_now = np.empty(c, np.int64), np.empty(c, np.int64), np.empty(c, np.int64)
    _leave_one_out(a, pair, med_now, n_pair)
    _leave_one_out(prev_a, pair, med_prev, n_prev)
    _leave_one_out(a, now_set, level, n_now)
    residual = np.empty(c)
    restarted = np.empty(c, np.bool_)
    new_loo = np.empty(c)
    for i in range(c):
        moving = math.isfinite(loo[i]) and n_pair[i] >= min_channels
        restarting = not moving and n_now[i] >= min_channels
        new_loo[i] = loo[i] + (med_now[i] - med_prev[i]) if moving else (level[i] if restarting else np.nan)
        residual[i] = a[i] - new_loo[i] if valid[i] else np.nan
        restarted[i] = restarting and valid[i]
    return residual, restarted, c0, arc_start, biases, new_offset, a, new_loo


@dataclass(frozen=True)
class ClockEpoch:
    """One epoch of a :class:`CodeClock`: ``residual_s`` (C,) (NaN: none), ``restarted`` (C,) bool (the
    channel's clock restarted: its difference chain breaks), ``common_s`` the common clock (NaN: none),
    ``arc_start`` (C,) bool (first epoch of a channel's arc), and the state to commit."""

    residual_s: np.ndarray
    restarted: np.ndarray
    common_s: float
    arc_start: np.ndarray
    state: tuple


class CodeClock:
    """The clocks of one code's ``n_channels`` channels (module docstring)."""

    def __init__(self, n_channels: int, *, fast: bool = True):
        self.n_channels = int(n_channels)
        self.fast = fast
        self.reset()

    def reset(self) -> None:
        c = self.n_channels
        nan = np.full(c, np.nan)
        # previous raw biases, common clock, per-arc offsets, previous aligned values, leave-one-out clocks
        self._state = (nan.copy(), np.nan, nan.copy(), nan.copy(), nan.copy())

    def step(self, bias_s: np.ndarray, excluded: np.ndarray) -> ClockEpoch:
        """One epoch: ``bias_s`` (C,) the channels' biases (NaN: none), ``excluded`` (C,) bool (left out of
        every clock). Does not change the state; :meth:`commit` the result to move on."""
        prev_b, c0, offset, prev_a, loo = self._state
        b = np.asarray(bias_s, dtype=np.float64)
        out = np.asarray(excluded, dtype=bool)
        if self.fast:
            residual, restarted, c0, arc_start, *state = clock_step_kernel(
                np.ascontiguousarray(b), np.ascontiguousarray(out), prev_b, float(c0), offset, prev_a, loo,
                MIN_CLOCK_CHANNELS)
            return ClockEpoch(residual, restarted, c0, arc_start, (state[0], c0, *state[1:]))
        valid = np.isfinite(b)
        # 1. common clock over the channels seen at both epochs and not excluded
        both = valid & np.isfinite(prev_b) & ~out
        if np.isfinite(c0) and both.any():
            c0 = c0 + float(np.median(b[both] - prev_b[both]))
        elif (valid & ~out).any():
            c0 = float(np.median(b[valid & ~out]))
        elif valid.any():
            c0 = float(np.median(b[valid]))
        else:
            c0 = np.nan
        # 2. alignment fixed at the first epoch of each arc
        arc_start = valid & ~np.isfinite(prev_b)
        offset = np.where(arc_start, b - c0, offset)
        offset = np.where(valid, offset, np.nan)
        a = np.where(valid, b - offset, np.nan)
        # 3. leave-one-out clocks over the other channels
        pair = valid & np.isfinite(prev_a) & ~out
        now_set = valid & ~out
        meds, ns = leave_one_out_medians_rows(np.stack([a, prev_a, a]), np.stack([pair, pair, now_set]))
        (med_now, med_prev, restart_level), n_pair, n_now = meds, ns[0], ns[2]
        moving = np.isfinite(loo) & (n_pair >= MIN_CLOCK_CHANNELS)
        restarting = ~moving & (n_now >= MIN_CLOCK_CHANNELS)
        new_loo = np.where(moving, loo + (med_now - med_prev), np.where(restarting, restart_level, np.nan))
        residual = np.where(valid, a - new_loo, np.nan)
        return ClockEpoch(residual, restarting & valid, c0, arc_start,
                          (np.where(valid, b, np.nan), c0, offset, a, new_loo))

    def commit(self, epoch: ClockEpoch) -> None:
        """Move on to the next epoch with the state ``epoch`` gave."""
        self._state = epoch.state
