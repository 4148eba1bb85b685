"""Two-way radio link truth (the swarm paper section 1 and Table 1).

The exchange (paper Fig. 1), in node clocks, every ``interval_s`` (slot ``k`` starts at ``s_k = k
interval_s`` on each node's own clock):

1. A transmits when its clock reads ``s_k`` (timestamp ``t1 = 0`` relative to the slot);
2. B stamps the arrival on its clock: ``T_i = h_B(t2) - s_k + delta_i`` (TOA noise ``delta_i``, plus an
   NLOS excess delay when that leg is reflected);
3. B stamps its reply at ``T_B`` (the reply slot, B's clock, with optional slot jitter; the stamp is
   reported) but really transmits ``t_p`` later (the unequal reply time, URT: a fixed part plus Gaussian
   jitter, paper eqs. 14-16; a schedule of changes of the fixed part can be given);
4. A stamps the arrival: ``T_r = h_A(t4) - s_k + delta_r``.

A node clock reads ``h(t) = t + x(t)`` with ``x`` its time error against true time; the offset to be
estimated is ``eps_k = x_B(t1) - x_A(t1)`` (B minus A at A's transmission). Without motion, URT and
noise, ``eps = (T_i - T_r + T_B) / 2`` (paper eq. 1).

Propagation is the exact light-time between moving endpoints in the inertial truth frame of
:mod:`chronofuse.models.kinematics` (and :mod:`chronofuse.models.earth_frame` for paths on the rotating
Earth): the reception instant solves ``c (t_r - t_e) = |r_R(t_r) - r_E(t_e)|`` (Newton's method to
machine precision). Both nodes may move in 3-D; what the exchange's offset then carries is derived in
:mod:`chronofuse.sync.measurement`. Besides the timestamps, each exchange reports the SNR the receiver
measured and A's own velocity along the line of sight to B in the truth frame (from its navigation and
B's broadcast position, with noise ``nav_velocity_sigma_m_s``). Noise and impairments:
:mod:`chronofuse.models.link_noise`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.models.kinematics import Trajectory, line_of_sight
from chronofuse.models.link_noise import (
    DOPPLER_SIGMA_TABLE_HZ,
    SNR_TABLE_DB,
    TOA_MODELS,
    TOA_SIGMA_TABLE_S,
    burst_loss,
    doppler_sigma_hz,
    nlos_excess_s,
    snr_at_range_db,
    toa_sigma_array_s,
    toa_sigma_s,
    velocity_sigma_array_m_s,
)
from chronofuse.models.oscillator import OscillatorModel, simulate_oscillator
from chronofuse.seeding import child_rng, root_seed
from chronofuse.validation import InputError, check_array, check_choice, check_scalar

__all__ = [
    "SNR_TABLE_DB",
    "TOA_SIGMA_TABLE_S",
    "DOPPLER_SIGMA_TABLE_HZ",
    "LinkModel",
    "Exchanges",
    "toa_sigma_s",
    "doppler_sigma_hz",
    "light_time_s",
    "simulate_exchanges",
    "paper_first_order_timestamps",
    "node_clock_error_s",
]

# Random-stream keys of one trial (child_seed(root, trial, key)); 0-3 are the original four, so a link
# without the later impairments draws exactly what it drew before them.
_KEY_TOA_UP, _KEY_TOA_DOWN, _KEY_URT, _KEY_DOPPLER = 0, 1, 2, 3
_KEY_REPLY, _KEY_NLOS_UP, _KEY_NLOS_DOWN, _KEY_LOSS, _KEY_NAV = 4, 5, 6, 7, 8


@dataclass(frozen=True)
class LinkModel:
    """Parameters of one two-way link (defaults are the paper's section 4 conditions).

    Attributes
    ----------
    interval_s : float
        Exchange interval, s (paper: 10 ms).
    reply_delay_s : float
        ``T_B``: B's reply slot time after the slot start, on B's clock, s (paper: 4 ms).
    urt_fixed_s : float
        Fixed part of the unequal reply time ``t_p``, s (paper: 20 ns).
    urt_jitter_s : float
        Standard deviation of the URT jitter, s (paper: 2 ns).
    snr_db : float
        Signal-to-noise ratio, dB (at ``snr_reference_range_m`` when that is given).
    toa_model : {"table", "crb", "none"}
        TOA noise from the paper's table, from the Cramér–Rao form, or none (truth checks).
    rms_bandwidth_hz : float
        RMS signal bandwidth of the Cramér–Rao form, Hz.
    carrier_hz : float
        Carrier frequency of the Doppler measurement, Hz. Default 1 GHz: the L-band tactical datalink
        band (960-1215 MHz); the paper does not state it (assumed).
    reply_jitter_s : float
        Sigma of B's reply-slot jitter, s: B's reply stamp ``T_B`` varies by this much from exchange to
        exchange (it is reported, so it is known; it moves the instant the offset is sampled at).
    snr_reference_range_m : float or None
        None: the SNR is ``snr_db`` at every range; else ``snr_db`` holds at this range and falls with
        free-space spreading (:func:`~chronofuse.models.link_noise.snr_at_range_db`).
    nlos_probability : float
        Probability that one leg's arrival is a reflected (NLOS) path, late by an exponential excess.
    nlos_mean_excess_s : float
        Mean excess delay of an NLOS arrival, s.
    loss_fraction : float
        Stationary fraction of exchanges lost (Gilbert–Elliott chain), in [0, 1), at most
        ``loss_burst_mean / (loss_burst_mean + 1)`` (0.5 for independent losses).
    loss_burst_mean : float
        Mean length of a loss burst, exchanges (1: independent losses).
    nav_velocity_sigma_m_s : float
        Noise of A's line-of-sight velocity as its navigation (GNSS/INS) reports it, m/s.
    """

    interval_s: float = 0.01
    reply_delay_s: float = 4e-3
    urt_fixed_s: float = 20e-9
    urt_jitter_s: float = 2e-9
    snr_db: float = 10.0
    toa_model: str = "table"
    rms_bandwidth_hz: float = 28.47e6
    carrier_hz: float = 1.0e9
    reply_jitter_s: float = 0.0
    snr_reference_range_m: float | None = None
    nlos_probability: float = 0.0
    nlos_mean_excess_s: float = 20e-9
    loss_fraction: float = 0.0
    loss_burst_mean: float = 1.0
    nav_velocity_sigma_m_s: float = 0.0

    def __post_init__(self):
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.reply_delay_s, "reply_delay_s", min_val=0.0, include_min=False)
        if self.reply_delay_s >= self.interval_s:
            raise InputError(f"{{reply_delay_s}} == {self.reply_delay_s}, must be < {{interval_s}} ({self.interval_s})",
                             fields=("reply_delay_s", "interval_s"))
        check_scalar(self.urt_fixed_s, "urt_fixed_s")
        check_scalar(self.urt_jitter_s, "urt_jitter_s", min_val=0.0)
        check_scalar(self.carrier_hz, "carrier_hz", min_val=0.0, include_min=False)
        check_scalar(self.reply_jitter_s, "reply_jitter_s", min_val=0.0, max_val=0.1 * self.reply_delay_s)
        if self.snr_reference_range_m is not None:
            check_scalar(self.snr_reference_range_m, "snr_reference_range_m", min_val=0.0, include_min=False)
        check_scalar(self.nlos_probability, "nlos_probability", min_val=0.0, max_val=1.0)
        check_scalar(self.nlos_mean_excess_s, "nlos_mean_excess_s", min_val=0.0)
        check_scalar(self.loss_fraction, "loss_fraction", min_val=0.0, max_val=1.0, include_max=False)
        check_scalar(self.loss_burst_mean, "loss_burst_mean", min_val=1.0)
        # Bursts of mean length L (P(bad -> good) = 1/L) reach a stationary loss of at most L / (L + 1); above
        # it P(good -> bad) would exceed 1 and the chain would lose every other exchange instead.
        if self.loss_fraction > self.loss_burst_mean / (self.loss_burst_mean + 1.0):
            need = self.loss_fraction / (1.0 - self.loss_fraction)
            raise InputError(f"{{loss_fraction}} == {self.loss_fraction:g} needs {{loss_burst_mean}} >= {need:.4g} "
                             f"(got {self.loss_burst_mean:g}): bursts of mean length L lose at most L/(L+1)",
                             fields=("loss_fraction", "loss_burst_mean"))
        check_scalar(self.nav_velocity_sigma_m_s, "nav_velocity_sigma_m_s", min_val=0.0)
        check_choice(self.toa_model, "toa_model", TOA_MODELS)
        if self.snr_reference_range_m is None:
            toa_sigma_s(self.snr_db, self.toa_model, self.rms_bandwidth_hz)
        else:
            check_scalar(self.snr_db, "snr_db")

    @property
    def toa_sigma_s(self) -> float:
        """TOA noise sigma of each timestamp at ``snr_db``, s."""
        return float(self.toa_sigma_at(self.snr_db))

    def toa_sigma_at(self, snr_db) -> np.ndarray:
        """TOA noise sigma, s, at per-exchange SNRs (the table clamps at its ends)."""
        return toa_sigma_array_s(snr_db, self.toa_model, self.rms_bandwidth_hz)

    def velocity_sigma_at(self, snr_db) -> np.ndarray:
        """Two-way Doppler velocity sigma, m/s, at per-exchange SNRs."""
        return velocity_sigma_array_m_s(snr_db, self.carrier_hz)

    @property
    def velocity_sigma_m_s(self) -> float:
        """Sigma of the two-way Doppler radial velocity at ``snr_db``, m/s: ``c sigma_f / (sqrt(2) f0)``;
        outside the paper's 4..20 dB table ``sigma_f`` is held at the table's end value."""
        return float(self.velocity_sigma_at(self.snr_db))

    def snr_at(self, range_m) -> np.ndarray:
        """The SNR, dB, at each range (constant unless ``snr_reference_range_m`` is given)."""
        return snr_at_range_db(self.snr_db, range_m, self.snr_reference_range_m)


def _readonly(a) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Exchanges:
    """The timestamps of ``steps`` exchanges in ``trials`` runs, and their truth.

    Measurements (what the nodes see), each of shape (trials, steps), seconds relative to the slot
    start (``t1 = 0``): ``t_i_s`` (B's arrival stamp), ``t_b_s`` (B's reply stamp), ``t_r_s`` (A's
    arrival stamp); ``velocity_m_s``: the Doppler radial velocity (positive: opening); ``snr_db``: the
    SNR the receivers measured; ``a_los_velocity_m_s``: A's velocity along the line of sight to B in the
    truth frame, as its navigation reports it. A lost exchange is NaN in every measured column.

    Truth (never given to an estimator): ``offset_s`` (``eps_k``), ``skew`` (``d eps / dt``),
    ``range_m`` and ``radial_velocity_m_s`` at A's transmission, ``tau_up_s`` and ``tau_down_s``
    (exact light-times), ``urt_s`` (the ``t_p`` each reply really had), ``nlos_up_s``/``nlos_down_s``
    (the excess delays of reflected arrivals, 0 when direct), ``lost`` (bool).

    ``link`` describes the run.
    """

    t_i_s: np.ndarray
    t_b_s: np.ndarray
    t_r_s: np.ndarray
    velocity_m_s: np.ndarray
    offset_s: np.ndarray
    skew: np.ndarray
    range_m: np.ndarray
    radial_velocity_m_s: np.ndarray
    tau_up_s: np.ndarray
    tau_down_s: np.ndarray
    urt_s: np.ndarray
    link: LinkModel
    snr_db: np.ndarray | None = None
    a_los_velocity_m_s: np.ndarray | None = None
    nlos_up_s: np.ndarray | None = None
    nlos_down_s: np.ndarray | None = None
    lost: np.ndarray | None = None

    def __post_init__(self):
        shape = np.shape(self.t_i_s)
        defaults = {"snr_db": np.full(shape, self.link.snr_db), "a_los_velocity_m_s": np.zeros(shape),
                    "nlos_up_s": np.zeros(shape), "nlos_down_s": np.zeros(shape), "lost": np.zeros(shape, dtype=bool)}
        for f in fields(self):
            if f.name == "link":
                continue
            value = getattr(self, f.name)
            if value is None:
                value = defaults[f.name]
            if f.name == "lost":
                value = np.array(value, dtype=bool)
                value.setflags(write=False)
                object.__setattr__(self, f.name, value)
            else:
                object.__setattr__(self, f.name, _readonly(value))

    @property
    def shape(self) -> tuple[int, int]:
        """(trials, steps)."""
        return self.t_i_s.shape

    @property
    def t_s(self) -> np.ndarray:
        """Nominal slot epochs ``k interval_s``, s, shape (steps,)."""
        return np.arange(self.shape[1]) * self.link.interval_s


def light_time_s(emitter, receiver, t_emit_s) -> np.ndarray:
    """Exact light-time, s, from ``emitter`` at true time ``t_emit_s`` (trials, k) to ``receiver``.

    Solves ``c tau = |r_R(t_e + tau) - r_E(t_e)|`` by Newton's method (derivative ``c - u . v_R``);
    stops when the correction is below 1e-18 s (8 iterations at most; 3 suffice below 1e5 m/s).
    """
    t_e = np.asarray(t_emit_s, dtype=np.float64)
    r_e = emitter.position_at(t_e)
    tau = np.linalg.norm(receiver.position_at(t_e) - r_e, axis=-1) / C
    for _ in range(8):
        d = receiver.position_at(t_e + tau) - r_e
        dist = np.linalg.norm(d, axis=-1)
        u = np.divide(d, dist[..., None], out=np.zeros_like(d), where=dist[..., None] > 0.0)
        rate = np.einsum("...i,...i->...", u, receiver.velocity_at(t_e + tau))
        step = (C * tau - dist) / (C - rate)
        tau = tau - step
        if np.max(np.abs(step), initial=0.0) < 1e-18:
            break
    return tau


def _interp_clock(x_s: np.ndarray, interval_s: float, t_s: np.ndarray) -> np.ndarray:
    """Clock time error at true times ``t_s`` (trials, k), linear between samples every interval_s."""
    pos = t_s / interval_s
    j = np.clip(np.floor(pos).astype(np.intp), 0, x_s.shape[1] - 2)
    frac = pos - j
    rows = np.arange(x_s.shape[0])[:, None]
    return x_s[rows, j] * (1.0 - frac) + x_s[rows, j + 1] * frac


def _clock_reading_time(x_s, interval_s, slot_s, reading_rel_s):
    """True time (relative to the slot epoch) at which the clock reads ``slot + reading_rel``:
    solves ``t + x(t) = slot + reading`` by fixed-point iteration (|dx/dt| << 1)."""
    rel = reading_rel_s - _interp_clock(x_s, interval_s, slot_s + reading_rel_s)
    for _ in range(3):
        rel = reading_rel_s - _interp_clock(x_s, interval_s, slot_s + rel)
    return rel


def simulate_exchanges(
    node_a,
    node_b,
    clock_a_s,
    clock_b_s,
    link: LinkModel,
    steps: int,
    seed,
    *,
    urt_change_s=None,
    first_trial: int = 0,
) -> Exchanges:
    """Simulate ``steps`` exchanges between A and B for every trial.

    Parameters
    ----------
    node_a, node_b : Trajectory or EarthRotating
        Paths in the inertial truth frame (trial axis 1 or ``trials``).
    clock_a_s, clock_b_s : array of shape (trials, m)
        Each node clock's time error ``x`` (s) sampled every ``link.interval_s`` from true time 0,
        ``m >= steps + 2`` (linear between samples); e.g. ``simulate_oscillator(...).x_s`` plus an
        initial offset and frequency offset.
    link : LinkModel
    steps : int
        Number of exchanges.
    seed : int or SeedSequence
        Trial ``i`` draws from ``child_seed(seed, first_trial + i, key)``: independent of the trial count
        (``first_trial`` lets a batch of links be cut into chunks that draw what the whole batch would).
    urt_change_s : array of shape (steps,) or (trials, steps), optional
        Added to the fixed URT at each exchange (a changed reply delay after calibration: a step, a ramp).

    Raises
    ------
    InputError
        If B's reply slot comes before the request arrives (``reply_delay_s`` shorter than the
        propagation time plus the offset).
    """
    check_scalar(steps, "steps", min_val=2, integer=True)
    steps = int(steps)
    xa = check_array(clock_a_s, "clock_a_s", ndim=2)
    xb = check_array(clock_b_s, "clock_b_s", ndim=2)
    if xa.shape != xb.shape:
        raise ValueError(f"clock_a_s has shape {xa.shape} and clock_b_s {xb.shape}, must agree")
    trials = xa.shape[0]
    if xa.shape[1] < steps + 2:
        raise ValueError(f"clock_a_s has {xa.shape[1]} samples, must have at least steps + 2 = {steps + 2}")
    for name, traj in (("node_a", node_a), ("node_b", node_b)):
        if traj.trials not in (1, trials):
            raise ValueError(f"{name} has {traj.trials} trials, must have 1 or {trials}")
    change = np.zeros((trials, steps))
    if urt_change_s is not None:
        c = check_array(urt_change_s, "urt_change_s", ndim=(1, 2))
        if c.shape[-1] != steps or (c.ndim == 2 and c.shape[0] not in (1, trials)):
            raise ValueError(f"urt_change_s has shape {c.shape}, must be ({steps},) or ({trials}, {steps})")
        change = change + c
    base = root_seed(seed)
    dt = link.interval_s
    slot = np.broadcast_to(np.arange(steps) * dt, (trials, steps))
    noise = np.empty((9, trials, steps))
    for i in range(trials):
        j = int(first_trial) + i
        for key in (_KEY_TOA_UP, _KEY_TOA_DOWN, _KEY_URT, _KEY_DOPPLER, _KEY_REPLY, _KEY_NAV):
            noise[key, i] = child_rng(base, j, key).standard_normal(steps)
        for key in (_KEY_NLOS_UP, _KEY_NLOS_DOWN):
            rng = child_rng(base, j, key)
            uniform = rng.random(steps)
            noise[key, i] = nlos_excess_s(uniform, rng.exponential(size=steps), link.nlos_probability,
                                          link.nlos_mean_excess_s)
        noise[_KEY_LOSS, i] = child_rng(base, j, _KEY_LOSS).random(steps)

    # 1. A transmits when its clock reads the slot start.
    t1_rel = _clock_reading_time(xa, dt, slot, np.zeros((trials, steps)))
    t1 = slot + t1_rel
    tau_up = light_time_s(node_a, node_b, t1)
    t2 = t1 + tau_up
    # 2. B's arrival stamp; 3. B's reply leaves t_p after its stamp T_B (itself jittered, and reported).
    t_i_true = t1_rel + tau_up + _interp_clock(xb, dt, t2)
    t_b = link.reply_delay_s + link.reply_jitter_s * noise[_KEY_REPLY]
    if np.any(t_i_true >= t_b):
        raise InputError(
            f"{{reply_delay_s}} == {link.reply_delay_s}, must exceed the propagation time plus the offset "
            f"(the request arrives {float(t_i_true.max()):.6g} s into B's slot)", fields=("reply_delay_s",))
    urt = link.urt_fixed_s + change + link.urt_jitter_s * noise[_KEY_URT]
    t3_rel = _clock_reading_time(xb, dt, slot, t_b + urt)
    t3 = slot + t3_rel
    tau_down = light_time_s(node_b, node_a, t3)
    t4 = t3 + tau_down
    t_r_true = t3_rel + tau_down + _interp_clock(xa, dt, t4)

    rng_m, u, v_a, v_b = line_of_sight(node_a, node_b, t1)
    vr = np.einsum("...i,...i->...", u, v_b - v_a)
    a_los = np.einsum("...i,...i->...", u, v_a)
    snr = link.snr_at(rng_m)
    sigma = link.toa_sigma_at(snr)
    nlos_up, nlos_down = noise[_KEY_NLOS_UP], noise[_KEY_NLOS_DOWN]
    lost = burst_loss(noise[_KEY_LOSS], link.loss_fraction, link.loss_burst_mean)
    offset = _interp_clock(xb, dt, t1) - _interp_clock(xa, dt, t1)
    skew = (_interp_clock(xb, dt, t1 + 1e-3) - _interp_clock(xa, dt, t1 + 1e-3) - offset) / 1e-3

    def measured(a):
        return np.where(lost, np.nan, a)

    return Exchanges(
        t_i_s=measured(t_i_true + sigma * noise[_KEY_TOA_UP] + nlos_up),
        t_b_s=measured(t_b),
        t_r_s=measured(t_r_true + sigma * noise[_KEY_TOA_DOWN] + nlos_down),
        velocity_m_s=measured(vr + link.velocity_sigma_at(snr) * noise[_KEY_DOPPLER]),
        offset_s=offset,
        skew=skew,
        range_m=rng_m,
        radial_velocity_m_s=vr,
        tau_up_s=tau_up,
        tau_down_s=tau_down,
        urt_s=urt,
        link=link,
        snr_db=measured(snr),
        a_los_velocity_m_s=measured(a_los + link.nav_velocity_sigma_m_s * noise[_KEY_NAV]),
        nlos_up_s=nlos_up,
        nlos_down_s=nlos_down,
        lost=lost,
    )


def paper_first_order_timestamps(distance_m, radial_velocity_m_s, offset_s, reply_delay_s):
    """The paper's noiseless model (eqs. 6 and 8, no URT): ``T_i = eps + S1/c`` and
    ``T_r = T_B - eps + S1/c + v (T_B - eps)/c``. Returns ``(T_i, T_r)``, s."""
    s1 = np.asarray(distance_m, dtype=np.float64)
    v = np.asarray(radial_velocity_m_s, dtype=np.float64)
    eps = np.asarray(offset_s, dtype=np.float64)
    t_i = eps + s1 / C
    t_r = reply_delay_s - eps + s1 / C + v * (reply_delay_s - eps) / C
    return t_i, t_r


def node_clock_error_s(
    model: OscillatorModel | None,
    steps: int,
    interval_s: float,
    seed,
    trials: int = 1,
    *,
    offset_s: float = 0.0,
    frequency_offset: float = 0.0,
) -> np.ndarray:
    """A node clock's time error ``x`` (s), shape (trials, steps + 2), sampled every ``interval_s``:
    ``offset_s + frequency_offset t`` plus the oscillator's noise and aging from
    :func:`~chronofuse.models.oscillator.simulate_oscillator` (none when ``model`` is None)."""
    check_scalar(steps, "steps", min_val=2, integer=True)
    check_scalar(offset_s, "offset_s")
    check_scalar(frequency_offset, "frequency_offset")
    m = int(steps) + 2
    t = np.arange(m) * interval_s
    x = np.broadcast_to(offset_s + frequency_offset * t, (int(trials), m)).copy()
    if model is not None:
        x += simulate_oscillator(model, m * interval_s, 1.0 / interval_s, seed, trials).x_s
    return x
