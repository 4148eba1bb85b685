"""Is the reference plausible? The disciplined oscillator's own prediction against each receiver and the fused reference.

A spoofer that drags every receiver together is invisible to cross-checks between receivers; the oscillator
sees it. The GPSDO knows the corrections it applied (``c_k``, the integral of its DAC steps), so from the
measured offset ``z_k = x_k - e_k`` it has ``y_k = z_k - c_k = x_free_k - e_k``: the free-running oscillator
against the reference, a series that does not depend on the loop. The free oscillator's phase is
predictable from its own past to within its noise (its Allan variance), so an ``e`` that moves faster
than that allows is implausible.

The test, per series (one per receiver, and the fused reference's), every second and at horizons
``W = 4, 8, ..., max_horizon_s``: block means ``B(k)`` of ``y`` over the last ``m = max(1, W / 4)`` seconds,
and their second difference ``D_W(k) = B(k) - 2 B(k - W) + B(k - 2 W)``, taken at the blocks' actual mean
times ``t_i`` (``B0 - B1 - (B1 - B2) (t0 - t1) / (t1 - t2)``: a block with gaps has its centre elsewhere,
and the free oscillator's frequency offset, up to 5e-9, would turn a 64 s shift into 320 ns). For the oscillator alone
``var D_W ~ 2 W^2 sigma_y^2(W)`` (the Allan variance's definition; NIST SP 1065 eq. 8, with
``sigma_y^2(W) = h0 / (2 W) + 2 ln2 h_-1 + (2 pi^2 / 3) h_-2 W``); the reference's own noise adds the
variance of the second difference of its block means (white: ``6 sigma_w^2 / m``; each Gauss-Markov term
exactly, from its autocovariance ``sigma^2 rho^|l|``), for a block half filled (the fewest samples the test
accepts; gaps are common where geometry disqualifies a receiver). The aging bound ``D`` adds a bias ``D W^2``. The series
is refused when ``|D_W| > k_sigma sqrt(var D_W) + D W^2`` at some horizon for ``persist`` consecutive
seconds. A drag of rate ``r`` starting at ``t0`` gives ``D_W = r (k - t0)`` until ``k - t0 = W``: the slowest
rate caught before the time error reaches a budget ``b`` is about ``min_W threshold(W) / W`` over the
horizons with ``threshold(W) < b`` (:meth:`DragMonitor.slowest_rate`).

Once refused, the series is compared with the holdover prediction made from before the excursion (the
block mean at ``k - 2W`` and the frequency to it over the longest horizon before it); it is admitted again only after
``readmit_s`` consecutive seconds (and at least the horizon it was refused at) within ``readmit_k_sigma`` of
that prediction's uncertainty, with its history
cleared (and, in fusion, its weight earned anew: :attr:`PlausibilityRun.readmitted`).

That tolerance grows with the time since the refusal: a step that stays (a coherent spoofer's 105 ns) is
inside it some minutes later, and the series comes back carrying it. Agreement then is no resolution, so
each series keeps ``unresolved``, the sum over its returns of the miss plus the tolerance it was let back in
on (after a refusal, or back from a gap and first agreeing only after seconds of disagreement):
:attr:`PlausibilityRun.unresolved_s`, the bound on the offset it may carry, which the state machine keeps off
the lock threshold (:mod:`.states`). A step that went back is let back in on a small miss.

A single sample far off (a 1PPS outlier, heavy-tailed: 2 % of pulses at 300 ns rms in the ``outliers``
scenario) holds a block mean for ``m`` seconds, and at ``W = 16`` (``m = 4``) that outlasts ``persist``: one
pulse refused a clean receiver for ``readmit_s``. So each sample enters the test *clipped*: beyond ``k_sigma``
of its prediction (the last 8 s block mean, and the frequency to it from the block 16 s before; the variance
of the two blocks' and the sample's reference noise, the frequency's error and the oscillator's wander over
the lead), it is taken at that limit. ``persist`` samples in a row beyond it on one side are a step and are
taken as they come for the next 24 s (the blocks then hold the new level): a step or a fast drag is seen
3 s later at most, an outlier moves a block mean by at most the limit. What the clip hides must stay bounded:
a train of large pulses (a spoofer's, or a receiver's fault) moves the reference's mean while each pulse
enters at the limit. So on each side the clip may hide 10 limits of excess in any 64 s (a bucket refilled at
10/64 of a limit a second); a sample beyond what is left is taken as it comes. What the clip hides of a
pulse train is then at most 10 limits / 64 of its mean (9 ns in open sky, 39 ns with the outliers
scenario's receivers), while one 6-limit outlier, or several smaller ones, are hidden. (A train too small
for the test's thresholds is not seen with the clip or without it: a 100 ns train at 2 s in 3 is not.)

A gap blinds the second differences: a drag or a step that happens while a series is away (an outage over the
spoofer's onset) is, after it, a frequency offset and a jump that no difference reaching back past the gap
can see until the history holds ``2W`` on each side. So where a series' samples stop, the prediction's anchor
is taken as above from the history before the gap; a series back after ``recheck_gap_s`` or more seconds is
*watched*: untrusted until its samples' mean agrees with the prediction within ``readmit_k_sigma`` (one sample
on, with that mean's own noise: usually at once), refused like any series when a check block misses it by more
than ``k_sigma``, and free of the watch after ``watch_s`` judged seconds (default ``2 max_horizon_s``: by then
a drag that began in the gap has left the prediction's widening tolerance, or is below what the oscillator can
tell). A series re-admitted after a refusal (its history cleared) is watched the same way against the
refusal's prediction: a drag that goes on is, to the second differences of the new history, a frequency offset.

:class:`DragMonitor` is the readable per-second core over (N, S) arrays; :meth:`DragMonitor.run` runs it
over (N, S, steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from chronofuse.discipline.kernels import CLIP_BLOCK_S, CLIP_LAG_S, CLIP_MAX, CLIP_SPACING_S, PREDICTION_HOLD_W
from chronofuse.discipline.servo import freeze
from chronofuse.validation import check_scalar

__all__ = ["ReferenceNoise", "DragMonitor", "PlausibilityRun", "oscillator_avar"]


def oscillator_avar(h0: float, hm1: float, hm2: float, tau_s: np.ndarray) -> np.ndarray:
    """Allan variance of white, flicker and random-walk FM at ``tau_s`` (NIST SP 1065 Table 3)."""
    tau = np.asarray(tau_s, dtype=np.float64)
    return h0 / (2.0 * tau) + 2.0 * math.log(2.0) * hm1 + 2.0 * math.pi**2 / 3.0 * hm2 * tau


@dataclass(frozen=True)
class ReferenceNoise:
    """A reference's phase noise as the designer models it: white ``white_sigma_s`` (outliers folded in as
    their variance) and first-order Gauss-Markov terms ``gauss_markov`` ((sigma_s, tau_s), ...)."""

    white_sigma_s: float
    gauss_markov: tuple[tuple[float, float], ...] = ()

    def scaled(self, factor: float) -> ReferenceNoise:
        """Every term's sigma times ``factor`` (a fused reference of ``R`` equal receivers: ``1 / sqrt(R)``)."""
        return ReferenceNoise(self.white_sigma_s * factor, tuple((s * factor, t) for s, t in self.gauss_markov))

    def block_var(self, m: int) -> float:
        """Variance of one ``m``-sample block mean."""
        var = self.white_sigma_s**2 / m
        for sigma, tau in self.gauss_markov:
            rho = math.exp(-1.0 / tau)
            lags = np.arange(1, m)
            var += sigma**2 / m**2 * (m + 2.0 * float(np.sum((m - lags) * rho**lags)))
        return float(var)

    def second_difference_var(self, m: int, lag: int) -> float:
        """Variance of ``B(k) - 2 B(k - lag) + B(k - 2 lag)`` of ``m``-sample block means (``lag >= m``)."""
        var = 6.0 * self.white_sigma_s**2 / m
        for sigma, tau in self.gauss_markov:
            rho = math.exp(-1.0 / tau)
            lags = np.arange(1, m)
            v0 = sigma**2 / m**2 * (m + 2.0 * np.sum((m - lags) * rho**lags))
            # cov(B(t), B(t - L)) for L >= m: sigma^2 rho^(L - m + 1) (sum_i rho^i)^2 / m^2.
            s = (1.0 - rho**m) / (1.0 - rho)

            def cov(L):
                return sigma**2 * rho ** (L - m + 1) * s * s / m**2

            var += 6.0 * v0 - 8.0 * cov(lag) + 2.0 * cov(2 * lag)
        return float(var)


@dataclass(frozen=True)
class PlausibilityRun:
    """(N, S, steps): ``plausible`` (the series trusted this second), ``readmitted`` (trusted again this second
    after a refusal), ``statistic`` (the largest ``|D_W| / threshold(W)`` of the second, NaN without one),
    ``unresolved_s`` (the bound on an offset the series was let back in with, s; module docstring),
    ``predicted_s`` (while refused, the series as the holdover prediction from before the excursion has it,
    s; NaN while trusted), ``return_bound_s`` (on the second a series back from a gap agrees at once, the
    tolerance of the prediction itself, its samples' noise left out: what a step in the gap could hide; NaN on
    every other second)."""

    plausible: np.ndarray
    readmitted: np.ndarray
    statistic: np.ndarray
    unresolved_s: np.ndarray | None = None
    predicted_s: np.ndarray | None = None
    return_bound_s: np.ndarray | None = None

    def __post_init__(self):
        freeze(self)


@dataclass(frozen=True)
class DragMonitor:
    """The plausibility test of one kind of series (module docstring).

    ``h0, hm1, hm2``: the oscillator's FM noise; ``drift_per_s``: its aging bound; ``noise``: the reference's
    (:class:`ReferenceNoise`); ``k_sigma``; ``persist``: seconds over threshold before a refusal;
    ``max_horizon_s``; ``readmit_s``: seconds of agreement with the holdover prediction, within ``readmit_k_sigma``
    of its uncertainty (stricter than the refusal: a series comes back only when clearly right), before re-admission;
    ``check_block_s``: the block mean compared with the prediction while refused or watched; ``recheck_gap_s``: the
    shortest gap after which a series is watched, ``watch_s`` for how many judged seconds; ``clip``: a sample
    beyond ``k_sigma`` of its short-term prediction enters the test at that limit (module docstring).
    """

    h0: float
    hm1: float
    hm2: float
    noise: ReferenceNoise
    drift_per_s: float = 0.0
    k_sigma: float = 5.0
    persist: int = 3
    max_horizon_s: int = 2048
    readmit_s: int = 300
    readmit_k_sigma: float = 3.0
    check_block_s: int = 16
    recheck_gap_s: int = 32
    watch_s: int | None = None
    clip: bool = True
    horizons: tuple[int, ...] = field(init=False)
    thresholds_s: tuple[float, ...] = field(init=False)
    clip_terms: tuple[float, float] = field(init=False)

    def __post_init__(self):
        check_scalar(self.k_sigma, "k_sigma", min_val=0.0, include_min=False)
        check_scalar(self.persist, "persist", min_val=1, integer=True)
        check_scalar(self.max_horizon_s, "max_horizon_s", min_val=4, integer=True)
        check_scalar(self.readmit_s, "readmit_s", min_val=1, integer=True)
        check_scalar(self.check_block_s, "check_block_s", min_val=1, integer=True)
        check_scalar(self.recheck_gap_s, "recheck_gap_s", min_val=1, integer=True)
        if self.watch_s is None:
            object.__setattr__(self, "watch_s", 2 * self.max_horizon_s)
        check_scalar(self.watch_s, "watch_s", min_val=1, integer=True)
        horizons = []
        w = 4
        while w <= self.max_horizon_s:
            horizons.append(w)
            w *= 2
        object.__setattr__(self, "horizons", tuple(horizons))
        object.__setattr__(self, "thresholds_s", tuple(self.threshold_s(w) for w in horizons))
        object.__setattr__(self, "clip_terms", self._clip_var_terms())

    @classmethod
    def for_oscillator(cls, osc, noise: ReferenceNoise, **kw) -> DragMonitor:
        """From an :class:`~chronofuse.models.oscillator.OscillatorModel`'s h-coefficients and aging."""
        return cls(osc.h.h0, osc.h.hm1, osc.h.hm2, noise, abs(osc.drift_per_s), **kw)

    @staticmethod
    def block(w: int, filled: bool = False) -> int:
        """The block length at horizon ``w``; ``filled``: the fewest samples a block may hold (half of it:
        the noise terms are taken for the worst block the test accepts)."""
        m = max(1, w // 4)
        return max(1, m // 2) if filled else m

    def statistic_var_s2(self, w: int) -> float:
        """``var D_W``: the oscillator's ``2 W^2 sigma_y^2(W)`` plus the reference's part."""
        osc = 2.0 * w * w * float(oscillator_avar(self.h0, self.hm1, self.hm2, w))
        return osc + self.noise.second_difference_var(self.block(w, filled=True), w)

    def threshold_s(self, w: int) -> float:
        return self.k_sigma * math.sqrt(self.statistic_var_s2(w)) + self.drift_per_s * w * w

    def slowest_rate(self, budget_s: float = 100e-9) -> tuple[float, int]:
        """``(rate s/s, horizon s)``: the slowest linear drag whose ``D_W = rate x W`` crosses the threshold at
        a horizon where the threshold is still inside ``budget_s`` (module docstring)."""
        best = (math.inf, 0)
        for w, thr in zip(self.horizons, self.thresholds_s):
            if thr < budget_s and thr / w < best[0]:
                best = (thr / w, w)
        return best

    def _lever_var(self, w: int) -> float:
        """The reference's part of a frequency measured between two blocks ``w`` apart, times ``w^2``."""
        return 2.0 * self.noise.block_var(self.block(int(w), filled=True)) if w > 1 else 0.0

    def _prediction_var_s2(self, h, wa, ma, check: bool = True):
        """Variance of the holdover prediction ``h`` seconds past its anchor (a block of ``ma`` samples, the
        frequency measured over ``wa`` seconds) against the check block: the oscillator's own wander over ``h``
        (``2 h^2 sigma_y^2(h)``), the anchor frequency's error (``h^2 sigma_y^2(wa)``), the two blocks' reference
        noise (their variances added: an upper bound whatever their correlation) and the reference's noise of
        the frequency estimate levered by ``(h / wa)^2``; ``check`` False: the prediction's own, without the
        check block's noise."""
        h = np.maximum(h, 1.0)
        wa = np.asarray(wa, dtype=np.float64)
        anchor_block = np.vectorize(lambda m: self.noise.block_var(max(1, int(m) // 2)), otypes=[float])(ma)
        lever = np.vectorize(self._lever_var, otypes=[float])(wa)
        own = 2.0 * h * h * oscillator_avar(self.h0, self.hm1, self.hm2, h) + h * h * oscillator_avar(self.h0, self.hm1,
                                                                                                 self.hm2, wa)
        if not check:
            return own + anchor_block + lever * (h / wa) ** 2
        return own + self.noise.block_var(max(1, self.check_block_s // 2)) + anchor_block + lever * (h / wa) ** 2

    def kernel_params(self) -> tuple:
        """(horizons, thresholds, lever variance and anchor-block variance per horizon, Gauss-Markov sigmas and
        taus, scalars) for the compiled twin :func:`~.kernels.plausibility_kernel`."""
        w = np.array(self.horizons, np.int64)
        lever = np.array([self._lever_var(int(x)) for x in w])
        block = np.array([self.noise.block_var(self.block(int(x), filled=True)) for x in w])
        gm = np.array(self.noise.gauss_markov, dtype=np.float64).reshape(-1, 2)
        scalars = np.array([self.h0, self.hm1, self.hm2, self.drift_per_s, self.k_sigma, self.persist, self.readmit_s,
                            self.check_block_s, self._ring, self.noise.block_var(max(1, self.check_block_s // 2)),
                            self.readmit_k_sigma, self.recheck_gap_s, self.watch_s, float(self.clip),
                            *self.clip_terms])
        recent = np.array([0.0] + [self.noise.block_var(n) for n in range(1, self.check_block_s + 1)])
        return (w, np.array(self.thresholds_s), lever, block, np.ascontiguousarray(gm[:, 0]), np.ascontiguousarray(gm[:, 1]),
                recent, scalars)

    def _clip_var_terms(self) -> tuple[float, float]:
        """The clip's variance terms (:meth:`_clip`): the last block's and one sample's reference noise (their
        variances added: an upper bound whatever their correlation), and the variance of the frequency measured
        between the last two blocks (their reference noise over the lag, and the oscillator's ``sigma_y^2``)."""
        half = self.noise.block_var(CLIP_BLOCK_S // 2)
        return (half + self.noise.block_var(1),
                2.0 * half / CLIP_LAG_S**2 + float(oscillator_avar(self.h0, self.hm1, self.hm2, CLIP_LAG_S)))

    def _clip(self, state, k, y, have):
        """``y`` as the test takes it: a sample beyond ``k_sigma`` of its prediction (the last ``CLIP_BLOCK_S``
        block mean and the frequency to it from the block ``CLIP_LAG_S`` before) enters at that limit; ``persist``
        such samples in a row on one side are a step, taken as they come for ``CLIP_BLOCK_S + CLIP_LAG_S``
        seconds (the blocks then hold the new level). Where the blocks are not there (history short, gaps), the
        sample is taken as it is."""
        b1, t1 = self._block_mean(state, k - 1, CLIP_BLOCK_S)
        b0, t0 = self._block_mean(state, k - 1 - CLIP_LAG_S, CLIP_BLOCK_S)
        run = state["clip_run"]
        for side in ("clip_hi", "clip_lo"):  # the excess it may still hide, refilled each second
            state[side] = np.minimum(CLIP_MAX, state[side] + CLIP_MAX / CLIP_SPACING_S)
        active = have & np.isfinite(b1) & np.isfinite(b0) & (k >= state["clip_off"])
        if not active.any():
            state["clip_run"] = np.where(have, 0, run)
            return y
        near, var_f = self.clip_terms
        with np.errstate(divide="ignore", invalid="ignore"):  # where not active
            h = k - t1
            pred = b1 + (b1 - b0) / (t1 - t0) * h
            lim = (self.k_sigma * np.sqrt(near + h * h * var_f + 2.0 * h * h * oscillator_avar(self.h0, self.hm1, self.hm2, h))
                   + self.drift_per_s * h * h)
            excess_hi, excess_lo = (y - pred) / lim - 1.0, (pred - y) / lim - 1.0
        over = active & (y - pred > lim)
        under = active & (pred - y > lim)
        run = np.where(over, np.maximum(run, 0) + 1, np.where(under, np.minimum(run, 0) - 1, np.where(have, 0, run)))
        step = np.abs(run) >= self.persist
        state["clip_off"] = np.where(step, k + CLIP_BLOCK_S + CLIP_LAG_S, state["clip_off"])
        state["clip_run"] = np.where(step, 0, run)
        # Clipped only while the side's bucket holds the excess (CLIP_MAX limits in CLIP_SPACING_S seconds).
        hi = over & ~step & (excess_hi <= state["clip_hi"])
        lo = under & ~step & (excess_lo <= state["clip_lo"])
        state["clip_hi"] = np.where(hi, state["clip_hi"] - excess_hi, state["clip_hi"])
        state["clip_lo"] = np.where(lo, state["clip_lo"] - excess_lo, state["clip_lo"])
        return np.where(hi, pred + lim, np.where(lo, pred - lim, y))

    @property
    def _ring(self) -> int:
        return 4 * self.horizons[-1] + 2

    def run(self, y, admitted, *, fast: bool = True) -> PlausibilityRun:
        """The test over (N, S, steps) series ``y`` offered where ``admitted``: the compiled
        :func:`~.kernels.plausibility_kernel` (``fast``) or :meth:`update` second by second (its twin)."""
        from chronofuse.discipline.kernels import plausibility_kernel

        y = np.asarray(y, dtype=np.float64)
        admitted = np.asarray(admitted, dtype=bool) & np.isfinite(y)
        shape, steps = y.shape[:-1], y.shape[-1]
        if fast:
            flat_y = np.ascontiguousarray(y.reshape(-1, steps))
            flat_a = np.ascontiguousarray(admitted.reshape(-1, steps))
            p, r, st, u, pr, rb = plausibility_kernel(flat_y, flat_a, *self.kernel_params())
            return PlausibilityRun(p.reshape(y.shape) != 0, r.reshape(y.shape) != 0, st.reshape(y.shape),
                                   u.reshape(y.shape), pr.reshape(y.shape), rb.reshape(y.shape))
        state = self.initial_state(shape)
        plausible = np.empty(y.shape, bool)
        readmitted = np.empty(y.shape, bool)
        stat = np.empty(y.shape)
        unresolved = np.empty(y.shape)
        predicted = np.empty(y.shape)
        returned = np.empty(y.shape)
        for k in range(steps):
            state, plausible[..., k], readmitted[..., k], stat[..., k] = self.update(state, y[..., k], admitted[..., k])
            unresolved[..., k] = state["unresolved"]
            predicted[..., k] = self.predicted(state)
            returned[..., k] = state["return_bound"]
        return PlausibilityRun(plausible, readmitted, stat, unresolved, predicted, returned)

    def predicted(self, state: dict) -> np.ndarray:
        """After :meth:`update` of second ``k``: each refused series at ``k`` as the holdover prediction made
        from before its excursion has it (the anchor's block mean and the frequency to it), NaN where trusted
        or where that frequency spans less than half the longest horizon (a history cleared by a re-admission
        shortly before: a frequency over a few seconds is worse than the servo's own), or where the excursion
        was refused at a horizon under :data:`~.kernels.PREDICTION_HOLD_W` (too fast for the servo to have
        learnt it: a step, a pulse train). A slow drag's frequency is what the servo learnt before the
        refusal; this is the oscillator's own, for holdover."""
        k = state["k"] - 1
        known = (~state["trusted"] & (state["anchor_w"] >= self.horizons[-1] // 2)
                 & (4 * state["anchor_m"] >= PREDICTION_HOLD_W))
        return np.where(known, state["anchor"] + state["anchor_f"] * (k - state["anchor_t"]), np.nan)

    # ---- the per-second core (readable twin of the kernel) ------------------------------------------------
    def initial_state(self, shape: tuple[int, ...]) -> dict:
        L = self._ring
        return {"k": 0, "csum": np.zeros(shape + (L,)), "tsum": np.zeros(shape + (L,)), "count": np.zeros(shape + (L,), np.int64),
                "start": np.zeros(shape, np.int64), "trusted": np.ones(shape, bool), "streak": np.zeros(shape, np.int64),
                "agree": np.zeros(shape, np.int64), "anchor": np.zeros(shape), "anchor_f": np.zeros(shape),
                "anchor_t": np.zeros(shape), "anchor_w": np.ones(shape, np.int64), "anchor_m": np.ones(shape, np.int64),
                "last": np.full(shape, -1, np.int64), "origin": np.full(shape, -1, np.int64), "watch": np.full(shape, -1, np.int64),
                "gap_anchor": np.full(shape, np.nan), "gap_f": np.zeros(shape), "gap_t": np.zeros(shape),
                "gap_w": np.ones(shape, np.int64), "clip_run": np.zeros(shape, np.int64),
                "clip_off": np.zeros(shape, np.int64), "clip_hi": np.full(shape, CLIP_MAX),
                "clip_lo": np.full(shape, CLIP_MAX), "waited": np.zeros(shape, np.int64),
                "unresolved": np.zeros(shape), "return_bound": np.full(shape, np.nan)}

    def _recent(self, state, k, m):
        """The mean, mean time and count of the samples in (k - m, k] since the history's ``start``, from one
        sample on (NaN, NaN, 0 without one)."""
        L = self._ring
        lo = np.maximum(k - m, state["start"] - 1)
        early = lo < 0
        i0 = np.where(early, 0, lo) % L
        c0 = np.where(early, 0.0, np.take_along_axis(state["csum"], i0[..., None], -1)[..., 0])
        t0 = np.where(early, 0.0, np.take_along_axis(state["tsum"], i0[..., None], -1)[..., 0])
        n0 = np.where(early, 0, np.take_along_axis(state["count"], i0[..., None], -1)[..., 0])
        n = state["count"][..., k % L] - n0
        safe = np.where(n > 0, n, 1)
        return (np.where(n > 0, (state["csum"][..., k % L] - c0) / safe, np.nan),
                np.where(n > 0, (state["tsum"][..., k % L] - t0) / safe, np.nan), n)

    def _block_mean(self, state, end, m):
        """Block mean over (end - m, end] per series and the mean time of its samples (NaN where that block
        reaches before the history's ``start`` or half of it is missing); ``end`` an absolute second."""
        L = self._ring
        ok = (end - m >= state["start"] - 1) & (end - m >= -1)
        i1, i0 = end % L, (end - m) % L
        c1, t1, n1 = state["csum"][..., i1], state["tsum"][..., i1], state["count"][..., i1]
        early = end - m < 0
        c0 = 0.0 if early else state["csum"][..., i0]
        t0 = 0.0 if early else state["tsum"][..., i0]
        n0 = 0 if early else state["count"][..., i0]
        n = n1 - n0
        ok = ok & (2 * n >= m) & (n > 0)
        safe = np.where(n > 0, n, 1)
        return np.where(ok, (c1 - c0) / safe, np.nan), np.where(ok, (t1 - t0) / safe, np.nan)

    def _anchor(self, state, end, m):
        """The holdover prediction's anchor: the ``m``-second block mean ending at second ``end`` and the
        frequency to it from the longest horizon's block before it; returns (phase, frequency, centre,
        frequency span). For an excursion seen at horizon ``w`` (the longest one over its threshold, so that the
        anchor most likely precedes the excursion's start) ``end = k - 2w``; for a gap, the gap's last
        second before it."""
        b1, c1 = self._block_mean(state, end, m)
        f = np.full(b1.shape, np.nan)
        span = np.zeros(b1.shape, np.int64)
        for wl in self.horizons[::-1]:
            ml = self.block(wl)
            b0, c0 = self._block_mean(state, end - wl, ml)
            take = np.isnan(f) & np.isfinite(b0)
            with np.errstate(divide="ignore", invalid="ignore"):  # where not taken (series not at an anchor)
                f = np.where(take, (b1 - b0) / (c1 - c0), f)
            span = np.where(take, wl, span)
        return b1, np.where(np.isnan(f), 0.0, f), c1, np.maximum(span, 1)

    def _frequency_miss(self, state, k, h, wa):
        """``(|f - anchor_f|, its sd, its aging allowance)`` (NaN miss: no frequency yet): the series' frequency
        since the refusal or the return (``origin``: what came before may be the drag's start) against the
        anchor's. Over the longest horizon ``S`` whose two blocks lie after the origin,
        ``f = (B(k) - B(k - S)) / (t1 - t0)`` against ``anchor_f``: the free oscillator's frequency moves between
        the two by about ``3 sigma_y^2(max(h, S))`` (a random walk's increment, 1.5x the Allan variance's two
        adjacent averages), the anchor's by
        ``sigma_y^2(wa)``, each block adds its reference noise, and the aging ``D (h + S)``. A drag that goes on
        at a constant rate leaves the phase prediction's widening cone only slowly (its sd grows as ``h^1.5``
        under random-walk FM); its frequency stays off by the drag's rate."""
        f = np.full(np.shape(h), np.nan)
        var = np.full(np.shape(h), np.nan)
        span = np.zeros(np.shape(h))
        for w in self.horizons[::-1]:
            m = self.block(w)
            b1, t1 = self._block_mean(state, k, m)
            b0, t0 = self._block_mean(state, k - w, m)
            take = np.isnan(f) & np.isfinite(b1) & np.isfinite(b0) & (t0 > state["origin"])
            if take.any():
                with np.errstate(divide="ignore", invalid="ignore"):
                    f = np.where(take, (b1 - b0) / (t1 - t0), f)
                noise = 2.0 * self.noise.block_var(self.block(w, filled=True)) / float(w) ** 2
                var = np.where(take, 3.0 * oscillator_avar(self.h0, self.hm1, self.hm2, np.maximum(h, float(w)))
                               + noise, var)
                span = np.where(take, float(w), span)
        lever = np.vectorize(lambda a: self._lever_var(int(a)) / float(a) ** 2 if a > 1 else 0.0, otypes=[float])(wa)
        var = var + oscillator_avar(self.h0, self.hm1, self.hm2, wa) + lever
        return np.abs(f - state["anchor_f"]), np.sqrt(var), self.drift_per_s * (np.maximum(h, 0.0) + span)

    def update(self, state: dict, y, admitted):
        """One second: ``y`` (N, S) the series (NaN: none), ``admitted`` (N, S) whether it is offered this
        second -> ``(state', plausible, readmitted, statistic)``; ``state`` is modified in place and returned."""
        y = np.asarray(y, dtype=np.float64)
        have = np.asarray(admitted, dtype=bool) & np.isfinite(y)
        k = state["k"]
        L = self._ring
        if self.clip:
            y = self._clip(state, k, y, have)
        c_prev = state["csum"][..., (k - 1) % L] if k > 0 else 0.0
        n_prev = state["count"][..., (k - 1) % L] if k > 0 else 0
        t_prev = state["tsum"][..., (k - 1) % L] if k > 0 else 0.0
        state["csum"][..., k % L] = c_prev + np.where(have, y, 0.0)
        state["tsum"][..., k % L] = t_prev + np.where(have, float(k), 0.0)
        state["count"][..., k % L] = n_prev + have
        trusted = state["trusted"]
        worst = np.full(y.shape, np.nan)
        first_w = np.zeros(y.shape, np.int64)
        for w, thr in zip(self.horizons, self.thresholds_s):
            m = self.block(w)
            (b0, t0), (b1, t1), (b2, t2) = (self._block_mean(state, k - j * w, m) for j in range(3))
            ratio = np.abs(b0 - b1 - (b1 - b2) * (t0 - t1) / (t1 - t2)) / thr
            worst = np.fmax(worst, ratio)
            exceed = np.isfinite(ratio) & (ratio > 1.0)
            first_w = np.where(exceed, w, first_w)  # the longest horizon over its threshold: its anchor is earliest
        # A second without a sample neither extends nor breaks a run (of exceedances, or of agreement).
        streak = np.where(have, np.where(trusted & (first_w > 0), state["streak"] + 1, 0), state["streak"])
        refuse = trusted & (streak >= self.persist)
        if refuse.any():
            for w in self.horizons:
                sel = refuse & (first_w == w)
                if sel.any():
                    a, f, c, span = self._anchor(state, k - 2 * w, self.block(w))
                    state["anchor"] = np.where(sel, a, state["anchor"])
                    state["anchor_f"] = np.where(sel, f, state["anchor_f"])
                    state["anchor_t"] = np.where(sel, c, state["anchor_t"])
                    state["anchor_w"] = np.where(sel, span, state["anchor_w"])
                    state["anchor_m"] = np.where(sel, self.block(w), state["anchor_m"])
        ms = self.check_block_s
        # A gap: where the samples stop, the prediction's anchor is taken from the history before it; a series
        # back after ``recheck_gap_s`` or more seconds without one is held to it (``watch``, below).
        stops = ~have & (state["last"] == k - 1)
        if stops.any():
            a, f, c, span = self._anchor(state, k - 1, ms)
            for key, value in (("gap_anchor", a), ("gap_f", f), ("gap_t", c), ("gap_w", span)):
                state[key] = np.where(stops, value, state[key])
        back = (have & trusted & ~refuse & (state["last"] >= 0) & (k - state["last"] - 1 >= self.recheck_gap_s)
                & np.isfinite(state["gap_anchor"]))
        if back.any():
            for key, gap_key in (("anchor", "gap_anchor"), ("anchor_f", "gap_f"), ("anchor_t", "gap_t"),
                                 ("anchor_w", "gap_w")):
                state[key] = np.where(back, state[gap_key], state[key])
            state["anchor_m"] = np.where(back, ms, state["anchor_m"])
        watch = np.where(back, 0, np.where(refuse, -1, state["watch"]))
        bs, ts = self._block_mean(state, k, ms)
        h = np.where(np.isfinite(ts), ts, k - (ms - 1) / 2.0) - state["anchor_t"]
        wa = state["anchor_w"].astype(np.float64)
        sd = np.sqrt(self._prediction_var_s2(h, wa, state["anchor_m"]))
        aging = self.drift_per_s * np.maximum(h, wa) ** 2
        judged = have & np.isfinite(bs)
        miss = np.abs(bs - (state["anchor"] + state["anchor_f"] * h))
        agree_now = judged & (miss < self.readmit_k_sigma * sd + aging)
        # Watched, a series is refused as a series is (``k_sigma``); it is trusted again from its first clear
        # agreement (``readmit_k_sigma``), and watched for ``watch_s`` judged seconds.
        watched = trusted & ~refuse & (watch >= 0)
        # Its first clear agreement is taken from the samples it has, one on (each second untrusted is a
        # second of holdover): their mean's own noise in place of the check block's.
        first = np.zeros(y.shape, bool)
        first_bound = np.zeros(y.shape)
        hidden = np.zeros(y.shape)
        f_miss = f_sd = f_aging = np.full(y.shape, np.nan)
        if (watched | ~trusted).any():  # nothing refused or watched (the usual second): nothing to compare
            bp, tp, n = self._recent(state, k, ms)
            hp = tp - state["anchor_t"]
            var_p = (self._prediction_var_s2(hp, wa, state["anchor_m"]) - self.noise.block_var(max(1, ms // 2))
                     + np.vectorize(self.noise.block_var, otypes=[float])(np.maximum(n, 1)))
            tolerance = (self.readmit_k_sigma * np.sqrt(np.maximum(var_p, 0.0))
                         + self.drift_per_s * np.maximum(hp, wa) ** 2)
            p_miss = np.abs(bp - (state["anchor"] + state["anchor_f"] * hp))
            first = watched & (watch == 0) & have & (n > 0) & (p_miss < tolerance)
            first_bound = np.where(first, p_miss + tolerance, 0.0)
            # What a step in the gap could hide in the prediction itself (the samples' noise averages out in
            # the watch that follows; the prediction's error does not).
            alone = self._prediction_var_s2(hp, wa, state["anchor_m"], check=False)
            hidden = (self.readmit_k_sigma * np.sqrt(np.maximum(alone, 0.0))
                      + self.drift_per_s * np.maximum(hp, wa) ** 2)
            f_miss, f_sd, f_aging = self._frequency_miss(state, k, h, wa)
        strayed = watched & judged & (~(miss < self.k_sigma * sd + aging) | (f_miss > self.k_sigma * f_sd + f_aging))
        refuse = refuse | strayed
        state["origin"] = np.where(refuse | back, k, state["origin"])
        watch = np.where(strayed, -1, np.where(first, 1, np.where(watched & judged & (watch > 0), watch + 1, watch)))
        watch = np.where(watch >= self.watch_s, -1, watch)
        refused = ~trusted
        # Back in only when clearly right in phase and, where it can be measured, in frequency: a slow drag that
        # goes on falls inside the phase prediction's widening cone, never inside the frequency's.
        agree_now = agree_now & ~(f_miss >= self.readmit_k_sigma * f_sd + f_aging)
        agree = np.where(refused, np.where(judged, np.where(agree_now, state["agree"] + 1, 0), state["agree"]), 0)
        readmit = refused & (agree >= np.maximum(self.readmit_s, 4 * state["anchor_m"]))
        # Let back in only once the prediction's tolerance covers what it missed (after a refusal, or after
        # seconds back from a gap without agreement): the offset the series may carry is bounded, not resolved.
        waited = np.where(back, 0, state["waited"])
        late = first & (waited > 0)
        state["return_bound"] = np.where(first & ~late, hidden, np.nan)
        state["unresolved"] = (state["unresolved"] + np.where(late, first_bound, 0.0)
                               + np.where(readmit, miss + self.readmit_k_sigma * sd + aging, 0.0))
        state["waited"] = np.where(watched & (watch == 0) & have & ~first, waited + 1, waited)
        # Re-admitted with its history cleared, a drag that goes on is, to the second differences, a frequency
        # offset from the start: the series stays watched against the refusal's prediction.
        watch = np.where(readmit, 1, watch)
        state["start"] = np.where(readmit, k + 1, state["start"])
        trusted = (trusted & ~refuse) | readmit
        state.update(trusted=trusted, streak=np.where(refuse | readmit, 0, streak), agree=np.where(readmit, 0, agree),
                     watch=watch, last=np.where(have, k, state["last"]), k=k + 1)
        # Back from a gap, the series is not trusted until its first samples agree with the prediction.
        return state, trusted & (watch != 0), readmit, worst
