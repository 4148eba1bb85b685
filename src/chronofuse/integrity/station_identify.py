"""Identification on a station's every channel and code, one epoch at a time: the stage of the station pipeline.

Per epoch ``k`` (:class:`StationIdentification`, a stage of :mod:`chronofuse.estimation.pipeline`):

1. **Residuals.** For each code, the channels' clock biases lose the other channels' clock
   (:class:`chronofuse.integrity.station_clock.CodeClock`, named satellites left out of every clock), and the
   residual's second difference ``d`` (m) joins the channel's window of ``n``.
2. **Arcs.** A channel's arc starts when its satellite rises (or returns after more than ``arc_gap`` epochs);
   its first ``arc_train`` epochs are its training: not tested, they fill its window and give the arc's own
   noise check (below). A rising satellite trains again; an arc is never tested with a window that spans
   its start.
3. **Tests.** Each channel's window is whitened with its code's model at its elevation
   (:class:`chronofuse.integrity.station_noise.CodeNoise`) and tested (:mod:`chronofuse.integrity.window_tests`:
   chi-square or GLR), giving a tail probability ``p_station``. The arc's check: its training innovations
   ``e`` (``m`` of them) update the window scale's inverse-gamma prior to ``(nu + m, (nu scale + sum e^2) / (nu
   + m))`` (the conjugate update), whose predictive tail ``p_arc`` is an F with ``nu + m`` degrees of freedom:
   the margin the arc's training length deserves. The channel's ``p = max(p_station, p_arc)``: an arc noisier
   than its code's model is tested against its own noise, a quieter one against the model.
4. **Station-level false-alarm control.** The station's ``P_fa`` per epoch is shared by every test made at
   the epoch: a share ``reserved`` goes to the tests outside the channels (the receiver clock's, made at
   ``reserved P_fa``), and the ``m`` channel tests (every channel of every code tested at the epoch) are each
   made at ``alpha = (1 - reserved) P_fa / m``; the station alarms when any test does. By Boole's inequality
   ``P(any test alarms) <= sum_i alpha_i = reserved P_fa + m alpha = P_fa`` under H0, whatever the dependence
   between the tests (the channels of one code share the others' clock, the codes of a satellite share its
   orbit and multipath): the operator's ``P_fa`` is the station's (a weighted Bonferroni correction; Sidak's
   ``1 - (1 - P_fa)^(1/m)``, exact for independent tests, differs from ``P_fa / m`` by less than 0.5 % at
   ``P_fa <= 1e-2``).
5. **Naming by exclusion.** While a channel of a satellite still in the clocks alarms, the satellite with
   the strongest evidence (the smallest ``p`` over its channels) is named, left out of every clock from this
   epoch, and every channel is tested again at this epoch: a fault stops moving the others' clocks the moment
   it is named, so it does not spread. There is no cap on how many are named; a satellite is named only while
   at least :data:`MIN_CLOCK_CHANNELS` + 1 satellites of its codes remain in the clocks (else the alarm stays
   ``unidentified``: no consistent subset is left to name it against). A code is tested at an epoch only while
   it holds at least :data:`MIN_CLOCK_CHANNELS` + 2 satellites not named, so that one can always be left out.
6. **Latch.** A named satellite stays named until its channels have been consistent (every tested ``p >=
   alpha``) for ``clear_after`` tested epochs and each channel's residual, averaged over a window, is back
   within ``clear_sigma`` standard deviations of its value over the window before it was named; or until it
   sets. Each raise and clear is an event.

Epoch verdict (``identification_state``): ``training`` while the station's noise trains; ``alarm`` while a
satellite is named or an alarm is unidentified; ``unavailable`` when fewer than :data:`MIN_TESTED_SATELLITES`
satellites outside the named ones are tested; else ``ok``.

``run`` steps the same core over every epoch of a copy of the state, so batch equals streaming.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.integrity.station_clock import MIN_CLOCK_CHANNELS, CodeClock
from chronofuse.integrity.station_noise import CodeNoise, fit_code_noise
from chronofuse.integrity.window_tests import WINDOW_TESTS, f_tail, signatures
from chronofuse.validation import check_choice, check_scalar

__all__ = ["StationIdentification", "IdentificationSettings", "MIN_TESTED_SATELLITES", "channel_differences"]

#: Fewest satellites, outside the named ones, with a tested channel for an epoch to be tested.
MIN_TESTED_SATELLITES = 4

_C = SPEED_OF_LIGHT_M_PER_S


@dataclass(frozen=True)
class IdentificationSettings:
    """The identification stage's settings: ``window`` (differences), ``pfa`` (the station's, per epoch),
    ``test`` (``"chi-square"`` or ``"glr"``), ``arc_train`` (epochs a new arc trains, default window + 2),
    ``arc_gap`` (missing epochs after which a returning satellite starts a new arc), ``clear_after`` (tested
    quiet epochs before a named satellite is cleared, default one window), ``clear_sigma``, ``confidence``
    (of the noise model's margin), ``reserved`` (the share of ``pfa`` kept for the tests outside the channels,
    e.g. the receiver clock's)."""

    window: int = 20
    pfa: float = 1e-3
    test: str = "chi-square"
    arc_train: int | None = None
    arc_gap: int = 10
    clear_after: int | None = None
    clear_sigma: float = 5.0
    confidence: float = 0.9
    reserved: float = 0.0

    def __post_init__(self):
        check_scalar(self.window, "window", min_val=3, integer=True)
        check_scalar(self.pfa, "pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        check_choice(self.test, "test", tuple(WINDOW_TESTS))
        if self.arc_train is not None:
            check_scalar(self.arc_train, "arc_train", min_val=3, integer=True)
        check_scalar(self.arc_gap, "arc_gap", min_val=0, integer=True)
        check_scalar(self.reserved, "reserved", min_val=0.0, max_val=1.0, include_max=False)

    @property
    def arc_train_epochs(self) -> int:
        return int(self.window) + 2 if self.arc_train is None else int(self.arc_train)

    @property
    def clear_epochs(self) -> int:
        return int(self.window) if self.clear_after is None else int(self.clear_after)


def channel_differences(bias_s: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """Second differences (m) of each channel's residual against the other channels of its code, with no
    satellite excluded: (channels, epochs), NaN where the chain is broken. What a code's noise is fitted on."""
    ch, ep = bias_s.shape
    clocks = [CodeClock(int((groups == g).sum())) for g in range(n_groups)]
    resid = np.full((ch, ep), np.nan)
    restart = np.zeros((ch, ep), dtype=bool)
    for k in range(ep):
        for g, clock in enumerate(clocks):
            idx = np.flatnonzero(groups == g)
            e = clock.step(bias_s[idx, k], np.zeros(idx.size, dtype=bool))
            clock.commit(e)
            resid[idx, k] = e.residual_s
            restart[idx, k] = e.restarted
    d = np.full((ch, ep), np.nan)
    d[:, 2:] = _C * (resid[:, 2:] - 2.0 * resid[:, 1:-1] + resid[:, :-2])
    broken = restart.copy()
    broken[:, 1:] |= restart[:, :-1]
    d[broken] = np.nan
    return d


@dataclass
class _Named:
    since: int
    ref_level_s: np.ndarray  # (channels of the satellite,) mean residual over the window before
    quiet: int = 0


@dataclass
class _State:
    r1: np.ndarray
    r2: np.ndarray
    window: np.ndarray  # (C, n) last n differences, newest last
    dof: np.ndarray
    arc_age: np.ndarray  # epochs since the arc started, -1 outside an arc
    gap: np.ndarray  # epochs since the channel was last seen
    arc_ss: np.ndarray
    arc_m: np.ndarray
    recent: np.ndarray  # (C, 2n) last residuals (s), newest last
    named: dict = field(default_factory=dict)
    prev_bias: np.ndarray | None = None  # (C,) last epoch's biases, for the receiver clock
    rx_clock: float = math.nan


class StationIdentification:
    """The identification stage (module docstring).

    ``channels``: ``(satellite, code)`` per channel (the rows of ``channel_bias_s``); ``settings``: an
    :class:`IdentificationSettings`; ``noise``: fitted models by code (None: :meth:`fit` fits them on its
    frame's training epochs).
    """

    needs: ClassVar[tuple[str, ...]] = ("t_ns", "channel_bias_s", "elevation_deg", "training")
    gives: ClassVar[tuple[str, ...]] = ("channel_statistic", "channel_p", "channel_dof", "channel_tested",
                                        "channel_excluded", "n_tests", "alpha", "named", "identification_events",
                                        "unidentified", "receiver_clock_s", "n_satellites_tested",
                                        "identification_state", "min_p_alpha")

    def __init__(self, channels, settings: IdentificationSettings | None = None, noise: dict | None = None):
        self.channels = [(str(s), str(c)) for s, c in channels]
        self.settings = settings or IdentificationSettings()
        self.noise = noise
        self.codes = list(dict.fromkeys(c for _, c in self.channels))
        self._groups = np.array([self.codes.index(c) for _, c in self.channels], dtype=np.intp)
        self.satellites = list(dict.fromkeys(s for s, _ in self.channels))
        self._sat_of = np.array([self.satellites.index(s) for s, _ in self.channels], dtype=np.intp)
        self._group_mask = [self._groups == g for g in range(len(self.codes))]
        self._group_idx = [np.flatnonzero(m) for m in self._group_mask]

    # -- fitting ---------------------------------------------------------------------------------------------

    def fit(self, frame=None) -> StationIdentification:
        """Fit each code's noise on the frame's ``training`` epochs (unless ``noise`` was given); reset."""
        if self.noise is None:
            if frame is None:
                raise ValueError("identification needs a training stretch or a noise model per code")
            train = np.asarray(frame["training"], dtype=bool)
            bias = np.asarray(frame["channel_bias_s"], dtype=np.float64)[:, train]
            el = np.asarray(frame["elevation_deg"], dtype=np.float64)[:, train]
            d = channel_differences(bias, self._groups, len(self.codes))
            fitted, self.fit_problems_ = {}, {}
            for g, code in enumerate(self.codes):
                rows = self._groups == g
                try:
                    fitted[code] = fit_code_noise(code, d[rows], el[rows], window=self.settings.window,
                                                  confidence=self.settings.confidence)
                except ValueError as err:
                    self.fit_problems_[code] = str(err)
            self.noise_ = fitted
        else:
            self.noise_ = dict(self.noise)
            self.fit_problems_ = {c: "no noise model given" for c in self.codes if c not in self.noise_}
        self._tables()
        self.reset()
        return self

    def _tables(self) -> None:
        n = int(self.settings.window)
        self._test = WINDOW_TESTS[self.settings.test]
        self._r_level_m2 = {code: noise.r_at(np.arange(91))[:, 0] / 6.0 for code, noise in self.noise_.items()}
        self._sig = signatures(n)

    def reset(self) -> None:
        self._clocks = [CodeClock(int((self._groups == g).sum())) for g in range(len(self.codes))]
        c, n = len(self.channels), int(self.settings.window)
        nan = np.full(c, np.nan)
        self._state = _State(nan.copy(), nan.copy(), np.full((c, n), np.nan), np.zeros(c, np.int64),
                             np.full(c, -1, np.int64), np.full(c, 10**9, np.int64), np.zeros(c), np.zeros(c, np.int64),
                             np.full((c, 2 * n), np.nan))
        self._k = 0

    # -- one epoch ---------------------------------------------------------------------------------------

    def _pass(self, bias, el, excluded_sats: set):
        """Residuals, differences and tests at this epoch with ``excluded_sats`` out of the clocks."""
        st, cfg = self._state, self.settings
        n = int(cfg.window)
        excl = np.isin(self._sat_of, [self.satellites.index(s) for s in excluded_sats])
        resid = np.full(len(self.channels), np.nan)
        restarted = np.zeros(len(self.channels), dtype=bool)
        epochs = []
        common = np.nan
        for g, clock in enumerate(self._clocks):
            idx = self._group_idx[g]
            e = clock.step(bias[idx], excl[idx])
            epochs.append(e)
            resid[idx] = e.residual_s
            restarted[idx] = e.restarted
            if g == 0:
                common = e.common_s
        r1 = np.where(restarted, np.nan, st.r1)
        r2 = np.where(restarted, np.nan, st.r2)
        d = _C * (resid - 2.0 * r1 + r2)
        ok = np.isfinite(d)
        window = np.concatenate([st.window[:, 1:], d[:, None]], axis=1)
        dof = np.where(ok, np.minimum(st.dof + 1, n), 0)
        stat = np.full(len(self.channels), np.nan)
        p = np.full(len(self.channels), np.nan)
        innov = np.full(len(self.channels), np.nan)
        for g, code in enumerate(self.codes):
            noise = self.noise_.get(code)
            if noise is None:
                continue
            here = self._group_mask[g] & ok
            for k in np.unique(dof[here]):
                rows = np.flatnonzero(here & (dof == k))
                dk = noise.whiteners[noise.whitener_index(el[rows])][:, :k, :k]
                w = np.einsum("nij,nj->ni", dk, window[rows, n - k:])
                innov[rows] = w[:, -1]
                s, pv = self._test(w, dk, noise.scale, noise.tail_dof)
                stat[rows], p[rows] = s, pv
        return resid, restarted, d, window, dof, stat, p, innov, epochs, common, excl

    def step(self, epoch) -> dict:
        """One epoch (``t_ns``, ``channel_bias_s`` (C,), ``elevation_deg`` (C,), ``training``) through the stage."""
        return self._step(np.asarray(epoch["channel_bias_s"], dtype=np.float64),
                          np.asarray(epoch["elevation_deg"], dtype=np.float64), bool(epoch["training"]))

    def _step(self, bias: np.ndarray, el: np.ndarray, training: bool) -> dict:
        st, cfg = self._state, self.settings
        n = int(cfg.window)
        valid = np.isfinite(bias)
        gap = np.where(valid, 0, st.gap + 1)
        arc_age = np.where(valid, np.where((st.arc_age < 0) | (st.gap > cfg.arc_gap), 0, st.arc_age + 1), st.arc_age)
        arc_age = np.where(~valid & (gap > cfg.arc_gap), -1, arc_age)
        trained = (arc_age >= cfg.arc_train_epochs) & valid
        named = dict(st.named)
        excluded = set(named)
        events: list[str] = []
        unidentified = False
        while True:
            resid, restarted, d, window, dof, stat, p_station, innov, epochs, common, excl = self._pass(bias, el, excluded)
            p = self._with_arc(p_station, stat, dof)
            tested = trained & (dof > 0) & np.isfinite(p) & (not training) & self._enough(valid, excl)
            m = int(tested.sum())
            alpha = cfg.pfa * (1.0 - cfg.reserved) / max(m, 1)
            alarm = tested & (p < alpha)
            candidates = alarm & ~excl
            if training or not candidates.any():
                break
            sat = self._strongest(candidates, p)
            if not self._can_exclude(sat, excluded, valid, tested):
                unidentified = True
                break
            excluded.add(sat)
            rows = np.flatnonzero(self._sat_of == self.satellites.index(sat))
            before = st.recent[rows, n:]
            seen = np.isfinite(before).sum(axis=1)
            level = np.where(seen > 0, np.nansum(before, axis=1) / np.maximum(seen, 1), np.nan)
            named[sat] = _Named(self._k, level)
            worst = rows[np.argmin(np.where(alarm[rows], p[rows], np.inf))]
            events.append(f"raise {sat}: {self.channels[worst][1]} p {p[worst]:.2g} < alpha {alpha:.2g}")
        # latch: clear named satellites consistent again (or set)
        recent = np.concatenate([st.recent[:, 1:], resid[:, None]], axis=1)
        for sat in list(named):
            if named[sat].since == self._k:
                continue
            rows = np.flatnonzero(self._sat_of == self.satellites.index(sat))
            if not valid[rows].any() and (gap[rows] > cfg.arc_gap).all():
                del named[sat]
                events.append(f"clear {sat}: not observed")
                continue
            rows_tested = rows[tested[rows]]
            if rows_tested.size:
                quiet = bool(np.all(p[rows_tested] >= alpha))
                named[sat].quiet = named[sat].quiet + 1 if quiet else 0
            if named[sat].quiet >= cfg.clear_epochs and self._level_back(sat, rows, recent, el, named[sat]):
                del named[sat]
                events.append(f"clear {sat}: {cfg.clear_epochs} epochs consistent and its level back")
        # commit
        for clock, e in zip(self._clocks, epochs):
            clock.commit(e)
        arc_ss = np.where(valid & ~trained & np.isfinite(innov), st.arc_ss + np.nan_to_num(innov) ** 2, st.arc_ss)
        arc_m = np.where(valid & ~trained & np.isfinite(innov), st.arc_m + 1, st.arc_m)
        restart_arc = valid & (arc_age == 0)
        arc_ss = np.where(restart_arc, np.where(np.isfinite(innov), innov**2, 0.0), arc_ss)
        arc_m = np.where(restart_arc, np.isfinite(innov).astype(np.int64), arc_m)
        rx = self._receiver_clock(bias, valid, np.isin(self._sat_of, [self.satellites.index(s) for s in named]))
        self._state = _State(resid, np.where(restarted, np.nan, st.r1), window, dof,
                             arc_age, gap, arc_ss, arc_m, recent, named, np.where(valid, bias, np.nan), rx)
        self._k += 1
        sats_tested = {self.satellites[i] for i in np.unique(self._sat_of[tested])} - set(named)
        if training:
            state = "training"
        elif named or unidentified:
            state = "alarm"
        elif len(sats_tested) < MIN_TESTED_SATELLITES:
            state = "unavailable"
        else:
            state = "ok"
        ratio = float(np.min(p[tested]) / alpha) if tested.any() else math.nan
        return {"channel_statistic": stat, "channel_p": p, "channel_dof": dof, "channel_tested": tested,
                "channel_excluded": np.isin(self._sat_of, [self.satellites.index(s) for s in named]),
                "n_tests": m, "alpha": alpha, "named": ",".join(sorted(named)), "identification_events": "; ".join(events),
                "unidentified": unidentified, "receiver_clock_s": rx, "n_satellites_tested": len(sats_tested),
                "identification_state": state, "min_p_alpha": ratio}

    def _enough(self, valid: np.ndarray, excl: np.ndarray) -> np.ndarray:
        """Per channel: whether its code has at least :data:`MIN_CLOCK_CHANNELS` + 2 satellites observed and
        not named at this epoch, so that a faulty one can be left out against a clock of the others (a code
        with fewer is not tested: an alarm there could not be attributed)."""
        inside = valid & ~excl
        counts = np.bincount(self._groups[inside], minlength=len(self.codes))
        return counts[self._groups] >= MIN_CLOCK_CHANNELS + 2

    def _receiver_clock(self, bias: np.ndarray, valid: np.ndarray, excluded: np.ndarray) -> float:
        """The receiver clock every channel shares: ``c(k) = c(k-1) + median (b(k) - b(k-1))`` over the
        channels of every code seen at both epochs and not named (the inter-code biases cancel in the
        increments, and the median over all codes is quieter than one code's); NaN at an epoch without any
        such channel, after which it restarts at the median of the biases (its difference chain broken)."""
        st = self._state
        prev = st.prev_bias if st.prev_bias is not None else np.full(bias.size, np.nan)
        both = valid & np.isfinite(prev) & ~excluded
        if math.isfinite(st.rx_clock) and both.any():
            return st.rx_clock + float(np.median(bias[both] - prev[both]))
        if math.isfinite(st.rx_clock) or not (valid & ~excluded).any():
            return math.nan
        return float(np.median(bias[valid & ~excluded]))

    def _with_arc(self, p_station: np.ndarray, stat: np.ndarray, dof: np.ndarray) -> np.ndarray:
        """``max(p_station, p_arc)`` (module docstring, step 3)."""
        st = self._state
        p = p_station.copy()
        for g, code in enumerate(self.codes):
            noise = self.noise_.get(code)
            rows = np.flatnonzero(self._group_mask[g] & (st.arc_m > 0) & (dof > 0) & np.isfinite(stat))
            if noise is None or rows.size == 0:
                continue
            nu = noise.tail_dof if math.isfinite(noise.tail_dof) else 1e6
            m = st.arc_m[rows]
            post_scale = (nu * noise.scale + st.arc_ss[rows]) / (nu + m)
            k = dof[rows]
            if self.settings.test == "chi-square":
                p_arc = f_tail(stat[rows] / (k * post_scale), k, nu + m)
            else:
                p_arc = np.minimum(1.0, 3 * k * f_tail(stat[rows] / post_scale, 1, nu + m))
            p[rows] = np.maximum(p[rows], p_arc)
        return p

    def _strongest(self, candidates: np.ndarray, p: np.ndarray) -> str:
        rows = np.flatnonzero(candidates)
        return self.channels[rows[np.argmin(p[rows])]][0]

    def _can_exclude(self, sat: str, excluded: set, valid: np.ndarray, tested: np.ndarray) -> bool:
        """Whether every code in which ``sat`` is tested at this epoch keeps more than
        :data:`MIN_CLOCK_CHANNELS` satellites in its clock. A code where it is not tested (no noise model, too
        few satellites for a clock, its arc still training) does not decide: losing a member there changes no
        verdict."""
        s = self.satellites.index(sat)
        mine = (self._sat_of == s) & tested
        for g in np.unique(self._groups[mine]):
            rows = (self._groups == g) & valid
            left = {self._sat_of[i] for i in np.flatnonzero(rows)} - {self.satellites.index(x) for x in excluded} - {s}
            if len(left) < MIN_CLOCK_CHANNELS + 1:
                return False
        return True

    def _level_back(self, sat: str, rows: np.ndarray, recent: np.ndarray, el: np.ndarray, named: _Named) -> bool:
        n = int(self.settings.window)
        for i, row in enumerate(rows):
            ref = named.ref_level_s[i]
            now = recent[row, n:]
            if not np.isfinite(ref) or np.isfinite(now).sum() < n // 2:
                continue
            code = self.channels[row][1]
            level = self._r_level_m2.get(code)
            if level is None:
                continue
            e = int(np.clip(np.rint(np.nan_to_num(el[row])), 0, 90))
            sigma_s = math.sqrt(2.0 * level[e] / n) / _C
            if abs(np.nanmean(now) - ref) > self.settings.clear_sigma * sigma_s:
                return False
        return True

    # -- batch -------------------------------------------------------------------------------------------

    def run(self, frame, progress=None) -> dict:
        """Every epoch of ``frame`` (columns with the step axis last) through a copy of the stage;
        ``progress(message, fraction)`` (:mod:`chronofuse.progress`) hears the fraction of epochs done."""
        core = copy.copy(self)
        core.reset()
        bias = np.asarray(frame["channel_bias_s"], dtype=np.float64)
        el = np.asarray(frame["elevation_deg"], dtype=np.float64)
        training = np.asarray(frame["training"], dtype=bool)
        steps = bias.shape[1]
        every = max(steps // 200, 1)
        rows = []
        for k in range(steps):
            if progress is not None and k % every == 0:
                progress(f"epoch {k + 1:,} of {steps:,}", k / steps)
            rows.append(core._step(bias[:, k], el[:, k], bool(training[k])))
        return _stack(rows, self.gives)


def _stack(rows: list[dict], names) -> dict:
    out = {}
    for name in names:
        values = [r[name] for r in rows]
        if values and isinstance(values[0], np.ndarray):
            out[name] = np.stack(values, axis=-1)
        elif values and isinstance(values[0], str):
            a = np.empty(len(values), dtype=object)
            a[:] = values
            out[name] = a
        else:
            out[name] = np.array(values)
    return out
