"""Two-way radio link truth (the swarm paper section 1 and Table 1).

The exchange (seed Fig. 1), in node clocks, every ``interval_s`` (slot ``k`` starts at ``s_k = k
interval_s`` on each node's own clock):

1. A transmits when its clock reads ``s_k`` (timestamp ``t1 = 0`` relative to the slot);
2. B stamps the arrival on its clock: ``T_i = h_B(t2) - s_k + delta_i`` (TOA noise ``delta_i``);
3. B stamps its reply at ``T_B`` (the reply delay, B's clock) but really transmits ``t_p`` later
   (the unequal reply time, URT: a fixed part plus Gaussian jitter, the source paper's eqs. 14-16);
4. A stamps the arrival: ``T_r = h_A(t4) - s_k + delta_r``.

A node clock reads ``h(t) = t + x(t)`` with ``x`` its time error against true time; the offset to be
estimated is ``eps_k = x_B(t1) - x_A(t1)`` (B minus A at A's transmission). Without motion, URT and
noise, ``eps = (T_i - T_r + T_B) / 2`` (the source paper's eq. 1).

Propagation is the exact light-time between moving endpoints in the truth frame of
:mod:`chronofuse.models.kinematics`: the reception instant solves ``c (t_r - t_e) = |r_R(t_r) -
r_E(t_e)|`` (Newton's method to machine precision). The source paper's model (eqs. 6 and 8) is its
first-order case: it takes the uplink delay as ``S1/c``, while a receiver receding at ``v`` makes it
``S1 / (c - v)``; the difference, ``S1 v / c^2`` to first order (0.89 ns at 80 km and 2000 m/s; 2.2 ns
at 100 km), depends on the frame and is kept here (see :func:`seed_first_order_timestamps`).

Noise (seed Table 1, SNR 4..20 dB in 2 dB steps): TOA sigma 2.5 .. 0.45 ns, Doppler frequency
sigma 190 .. 30 Hz; between grid points the tables are interpolated linearly in dB. The Cramér–Rao
alternative is ``sigma_TOA = 1 / (2 pi beta sqrt(2 SNR))`` for RMS bandwidth ``beta`` (Kay,
*Fundamentals of Statistical Signal Processing: Estimation*, 1993, example 3.13, with ``2E/N0 = 2
SNR``). Doppler velocity: each one-way carrier-frequency estimate has the table's sigma; the two
shifts carry the clocks' frequency offset with opposite signs, so ``v = -c (f_up + f_down) / (2 f0)``
(the source paper's eq. 12) has sigma ``c sigma_f / (sqrt(2) f0)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.models.kinematics import Trajectory
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
    "seed_first_order_timestamps",
    "node_clock_error_s",
]

#: The swarm paper Table 1: SNR grid, dB.
SNR_TABLE_DB = np.array([4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0])
#: The swarm paper Table 1: TOA estimation error sigma at each SNR, s.
TOA_SIGMA_TABLE_S = np.array([2.5, 2.0, 1.6, 1.25, 1.0, 0.8, 0.6, 0.5, 0.45]) * 1e-9
#: The swarm paper Table 1: carrier-frequency (Doppler) noise n_i, n_r at each SNR, Hz.
DOPPLER_SIGMA_TABLE_HZ = np.array([190.0, 152.0, 121.0, 96.0, 76.0, 61.0, 48.0, 36.0, 30.0])

_TOA_MODELS = ("table", "crb", "none")
# Random-stream keys of one trial (child_seed(root, trial, key)).
_KEY_TOA_UP, _KEY_TOA_DOWN, _KEY_URT, _KEY_DOPPLER = 0, 1, 2, 3


def _in_table(snr_db: float, what: str) -> float:
    check_scalar(snr_db, "snr_db")
    if not SNR_TABLE_DB[0] <= snr_db <= SNR_TABLE_DB[-1]:
        raise InputError(
            f"{{snr_db}} == {snr_db}, must be within [{SNR_TABLE_DB[0]:g}, {SNR_TABLE_DB[-1]:g}] dB for the source paper's {what} "
            "table (use the Cramér-Rao TOA model for other SNRs)", fields=("snr_db",))
    return float(snr_db)


def toa_sigma_s(snr_db: float, model: str = "table", rms_bandwidth_hz: float = 28.47e6) -> float:
    """TOA noise sigma, s, at ``snr_db``: the source paper's table (interpolated), the Cramér–Rao form, or
    ``"none"`` (noiseless timestamps, for truth checks).

    The default RMS bandwidth makes the Cramér–Rao form give the table's 1.25 ns at 10 dB.
    """
    check_choice(model, "toa_model", _TOA_MODELS)
    if model == "none":
        return 0.0
    if model == "table":
        return float(np.interp(_in_table(snr_db, "TOA"), SNR_TABLE_DB, TOA_SIGMA_TABLE_S))
    check_scalar(snr_db, "snr_db")
    check_scalar(rms_bandwidth_hz, "rms_bandwidth_hz", min_val=0.0, include_min=False)
    snr = 10.0 ** (snr_db / 10.0)
    return 1.0 / (2.0 * math.pi * rms_bandwidth_hz * math.sqrt(2.0 * snr))


def doppler_sigma_hz(snr_db: float) -> float:
    """One-way carrier-frequency noise sigma, Hz, at ``snr_db`` (seed Table 1, interpolated)."""
    return float(np.interp(_in_table(snr_db, "Doppler"), SNR_TABLE_DB, DOPPLER_SIGMA_TABLE_HZ))


@dataclass(frozen=True)
class LinkModel:
    """Parameters of one two-way link (defaults are the source paper's section 4 conditions).

    Attributes
    ----------
    interval_s : float
        Exchange interval, s (seed: 10 ms).
    reply_delay_s : float
        ``T_B``: B's reply slot time after the slot start, on B's clock, s (seed: 4 ms).
    urt_fixed_s : float
        Fixed part of the unequal reply time ``t_p``, s (seed: 20 ns).
    urt_jitter_s : float
        Standard deviation of the URT jitter, s (seed: 2 ns).
    snr_db : float
        Signal-to-noise ratio, dB.
    toa_model : {"table", "crb", "none"}
        TOA noise from the source paper's table, from the Cramér–Rao form, or none (truth checks).
    rms_bandwidth_hz : float
        RMS signal bandwidth of the Cramér–Rao form, Hz.
    carrier_hz : float
        Carrier frequency of the Doppler measurement, Hz. Default 1 GHz: the L-band tactical datalink
        band (960-1215 MHz); the source paper does not state it (assumed).
    """

    interval_s: float = 0.01
    reply_delay_s: float = 4e-3
    urt_fixed_s: float = 20e-9
    urt_jitter_s: float = 2e-9
    snr_db: float = 10.0
    toa_model: str = "table"
    rms_bandwidth_hz: float = 28.47e6
    carrier_hz: float = 1.0e9

    def __post_init__(self):
        check_scalar(self.interval_s, "interval_s", min_val=0.0, include_min=False)
        check_scalar(self.reply_delay_s, "reply_delay_s", min_val=0.0, include_min=False)
        if self.reply_delay_s >= self.interval_s:
            raise InputError(f"{{reply_delay_s}} == {self.reply_delay_s}, must be < {{interval_s}} ({self.interval_s})",
                             fields=("reply_delay_s", "interval_s"))
        check_scalar(self.urt_fixed_s, "urt_fixed_s")
        check_scalar(self.urt_jitter_s, "urt_jitter_s", min_val=0.0)
        check_scalar(self.carrier_hz, "carrier_hz", min_val=0.0, include_min=False)
        toa_sigma_s(self.snr_db, self.toa_model, self.rms_bandwidth_hz)

    @property
    def toa_sigma_s(self) -> float:
        """TOA noise sigma of each timestamp, s."""
        return toa_sigma_s(self.snr_db, self.toa_model, self.rms_bandwidth_hz)

    @property
    def velocity_sigma_m_s(self) -> float:
        """Sigma of the two-way Doppler radial velocity, m/s: ``c sigma_f / (sqrt(2) f0)``; outside the
        source paper's 4..20 dB table (Cramér–Rao TOA model) ``sigma_f`` is held at the table's end value."""
        sigma_f = doppler_sigma_hz(min(max(self.snr_db, SNR_TABLE_DB[0]), SNR_TABLE_DB[-1]))
        return C * sigma_f / (math.sqrt(2.0) * self.carrier_hz)


def _readonly(a) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Exchanges:
    """The timestamps of ``steps`` exchanges in ``trials`` runs, and their truth.

    Measurements (what the nodes see), each of shape (trials, steps), seconds relative to the slot
    start (``t1 = 0``): ``t_i_s`` (B's arrival stamp), ``t_b_s`` (B's reply stamp, = ``reply_delay_s``),
    ``t_r_s`` (A's arrival stamp); ``velocity_m_s``: the Doppler radial velocity (positive: opening).

    Truth (never given to an estimator): ``offset_s`` (``eps_k``), ``skew`` (``d eps / dt``),
    ``range_m`` and ``radial_velocity_m_s`` at A's transmission, ``tau_up_s`` and ``tau_down_s``
    (exact light-times), ``urt_s`` (the ``t_p`` each reply really had).

    ``interval_s``, ``snr_db`` and ``link`` describe the run.
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

    def __post_init__(self):
        for f in fields(self):
            if f.name != "link":
                object.__setattr__(self, f.name, _readonly(getattr(self, f.name)))

    @property
    def shape(self) -> tuple[int, int]:
        """(trials, steps)."""
        return self.t_i_s.shape

    @property
    def t_s(self) -> np.ndarray:
        """Nominal slot epochs ``k interval_s``, s, shape (steps,)."""
        return np.arange(self.shape[1]) * self.link.interval_s


def light_time_s(emitter: Trajectory, receiver: Trajectory, t_emit_s) -> np.ndarray:
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
    node_a: Trajectory,
    node_b: Trajectory,
    clock_a_s,
    clock_b_s,
    link: LinkModel,
    steps: int,
    seed,
) -> Exchanges:
    """Simulate ``steps`` exchanges between A and B for every trial.

    Parameters
    ----------
    node_a, node_b : Trajectory
        Paths in the truth frame (trial axis 1 or ``trials``).
    clock_a_s, clock_b_s : array of shape (trials, m)
        Each node clock's time error ``x`` (s) sampled every ``link.interval_s`` from true time 0,
        ``m >= steps + 2`` (linear between samples); e.g. ``simulate_oscillator(...).x_s`` plus an
        initial offset and frequency offset.
    link : LinkModel
    steps : int
        Number of exchanges.
    seed : int or SeedSequence
        Trial ``i`` draws from ``child_seed(seed, i, key)``: independent of the trial count.

    Raises
    ------
    ValueError
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
    base = root_seed(seed)
    dt = link.interval_s
    slot = np.broadcast_to(np.arange(steps) * dt, (trials, steps))

    # 1. A transmits when its clock reads the slot start.
    t1_rel = _clock_reading_time(xa, dt, slot, np.zeros((trials, steps)))
    t1 = slot + t1_rel
    tau_up = light_time_s(node_a, node_b, t1)
    t2 = t1 + tau_up
    # 2. B's arrival stamp; 3. B's reply leaves t_p after its stamp T_B.
    t_i_true = t1_rel + tau_up + _interp_clock(xb, dt, t2)
    if np.any(t_i_true >= link.reply_delay_s):
        raise InputError(
            f"{{reply_delay_s}} == {link.reply_delay_s}, must exceed the propagation time plus the offset "
            f"(the request arrives {float(t_i_true.max()):.6g} s into B's slot)", fields=("reply_delay_s",))
    noise = np.empty((4, trials, steps))
    for i in range(trials):
        for key in (_KEY_TOA_UP, _KEY_TOA_DOWN, _KEY_URT, _KEY_DOPPLER):
            noise[key, i] = child_rng(base, i, key).standard_normal(steps)
    urt = link.urt_fixed_s + link.urt_jitter_s * noise[_KEY_URT]
    t3_rel = _clock_reading_time(xb, dt, slot, link.reply_delay_s + urt)
    t3 = slot + t3_rel
    tau_down = light_time_s(node_b, node_a, t3)
    t4 = t3 + tau_down
    t_r_true = t3_rel + tau_down + _interp_clock(xa, dt, t4)

    sigma = link.toa_sigma_s
    rel = node_b.position_at(t1) - node_a.position_at(t1)
    rng_m = np.linalg.norm(rel, axis=-1)
    u = np.divide(rel, rng_m[..., None], out=np.zeros_like(rel), where=rng_m[..., None] > 0.0)
    vr = np.einsum("...i,...i->...", u, node_b.velocity_at(t1) - node_a.velocity_at(t1))
    offset = _interp_clock(xb, dt, t1) - _interp_clock(xa, dt, t1)
    skew = (_interp_clock(xb, dt, t1 + 1e-3) - _interp_clock(xa, dt, t1 + 1e-3) - offset) / 1e-3
    return Exchanges(
        t_i_s=t_i_true + sigma * noise[_KEY_TOA_UP],
        t_b_s=np.full((trials, steps), link.reply_delay_s),
        t_r_s=t_r_true + sigma * noise[_KEY_TOA_DOWN],
        velocity_m_s=vr + link.velocity_sigma_m_s * noise[_KEY_DOPPLER],
        offset_s=offset,
        skew=skew,
        range_m=rng_m,
        radial_velocity_m_s=vr,
        tau_up_s=tau_up,
        tau_down_s=tau_down,
        urt_s=urt,
        link=link,
    )


def seed_first_order_timestamps(distance_m, radial_velocity_m_s, offset_s, reply_delay_s):
    """The source paper's noiseless model (eqs. 6 and 8, no URT): ``T_i = eps + S1/c`` and
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
