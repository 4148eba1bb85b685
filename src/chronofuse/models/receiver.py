"""GNSS timing-receiver truth model: :func:`simulate_receivers`.

The receiver's parameters are a :class:`~chronofuse.models.receiver_model.ReceiverModel` (whose
docstring holds the open-sky calibration); where it stands, a
:class:`~chronofuse.models.environment.ReceiverEnvironment`. A run returns :class:`ReceiverTruth`: what
is true (the 1PPS edge error, the drag-off) beside what the receivers report every epoch, a
:class:`chronofuse.epochs.ReceiverEpochs` (the record the NMEA/UBX readers also produce).

What one receiver produces, every pulse ``k`` (times ``t_k = k dt``, ``dt = 1 / rate_hz``)
-------------------------------------------------------------------------------------------
The receiver's navigation solution estimates its own clock bias ``b_hat = b + e + s``, where ``b`` is
the true bias of its free-running oscillator against GNSS system time, ``s`` a spoofer's drag-off
(zero unless spoofed) and ``e`` the timing error of the solution::

    e_k = (G_k / gdop_median) sigma_w w_k       white noise, scaled with the geometry (TDOP ~ GDOP)
        + m_k                                   multipath, first-order Gauss-Markov (sigma_mp, tau_mp)
        + a_k                                   slow wander, first-order Gauss-Markov (sigma_wd, tau_wd)
        + o_k                                   single-pulse outliers (prob. per pulse, N(0, sigma_o))
        + sum_{i<=k} j_i                        persistent jumps (prob. per second, N(0, sigma_j))

``m`` and ``a`` (and the geometry below) are first-order Gauss-Markov processes,
:func:`chronofuse.models.noise.gauss_markov`, started from their stationary law.

The 1PPS edge can only leave on a tick of the receiver's own clock (period ``T = 1 / tick_hz``). The
receiver aims at local time ``L* = t_k + b_hat_k`` and emits on the nearest tick, at local times
``T (theta + n)`` (``theta``: the tick phase, uniform per receiver), so the edge carries the sawtooth
``q_k = T (round(u_k) - u_k)``, ``u_k = L*_k / T - theta``, within ``[-T/2, T/2]``. Hence

- ``pps_error_s = e + s + q`` (truth: edge time minus true GNSS time; positive = late), NaN without
  a pulse; the receiver reports (in :class:`~chronofuse.epochs.ReceiverEpochs`)
- ``qerr_s = -q`` rounded to 1 ps, the quantization error the receiver announces in advance, with the
  sign of u-blox UBX-TIM-TP ``qErr``: a time-interval counter started by the reference and stopped by
  the receiver's pulse reads ``pps_error_s``, and *adding* ``qErr`` to that reading removes the
  sawtooth (A. Wallin, "uBlox F9T qErr correction", anderswallin.net, 2019: "the qErr is applied with
  a + sign to the measured time-interval"). So ``pps_error_s + qerr_s = e + s`` to within 0.5 ps;
- ``clock_bias_s = b_hat`` (what NAV-CLOCK reports and an integrity monitor watches), NaN without a fix.
  ``b`` is a free-running TCXO: a constant frequency offset (uniform within ``+-clock_freq_offset_max``),
  white FM (``h0``) and random-walk FM (``h_-2``), as the HOD detector's clock model
  (phase increments of variance ``h0 dt / 2``; frequency increments of variance ``2 pi^2 h_-2 dt``).

Geometry: a unit-variance Gauss-Markov latent ``z_k`` (time constant ``gdop_tau_s``) gives
``GDOP = max(1, gdop_median exp(gdop_log_sigma z))`` (log-normal) and the number of satellites used
``n_sats = clip(round(n_sats_median - n_sats_spread z), 4, n_sats_max)`` (fewer satellites, worse
geometry). There is no fix during an outage (Poisson starts at ``outage_rate_hz``, geometric lengths of
mean ``outage_mean_s``), in a jamming window, or when GDOP exceeds ``gdop_fix_max``; without a fix the
receiver outputs no 1PPS (``pps_error_s``, and the reported ``qerr_s``, ``clock_bias_s`` and ``gdop``,
are NaN) and reports 0 to 3 satellites (0 when jammed).

Reports: ``fix_mode`` 3 (a timing receiver's time fix) with a fix, else 1 (no fix); ``time_valid`` is the
fix; GDOP is the only dilution modelled (the other DOPs and the clock drift are NaN, absent); ``leap_s``
and ``leap_pending`` (+1 before an announced insertion) are common to all receivers.

Epochs are integers: GPS nanoseconds since 1980-01-06T00:00:00 (int64, :mod:`chronofuse.timescale`)
on a grid of whole seconds; the receivers' UTC label is ``gps - leap_s`` (POSIX style: an inserted leap
second repeats the label of the following midnight). The default start, :data:`DEFAULT_START_GPS_S`,
is 2025-01-01T00:00:00 UTC, when GPS - UTC = 18 s.

Randomness: :func:`chronofuse.seeding.root_seed` (an int or SeedSequence reproduces, a Generator is
consumed); stream ``(i, j)`` (trial ``i``, receiver ``j``) draws from the child with spawn key
``root.spawn_key + (i, j)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from chronofuse.epochs import ReceiverEpochs
from chronofuse.record import EpochRecord
from chronofuse.models.clock import two_state_clock_phase_s
from chronofuse.models.environment import ReceiverEnvironment, receiver_environment
from chronofuse.models.noise import gauss_markov
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.seeding import SeedLike, child_rng, root_seed
from chronofuse.timescale import NS_PER_S, gps_minus_utc_s, utc_to_gps_ns
from chronofuse.validation import InputError, check_scalar

__all__ = [
    "DEFAULT_START_GPS_S",
    "GPS_MINUS_UTC_S",
    "ReceiverModel",
    "ReceiverTruth",
    "simulate_receivers",
    "sawtooth_s",
]

#: 2025-01-01T00:00:00 UTC in GPS seconds since 1980-01-06 (16,432 days plus 18 leap seconds).
DEFAULT_START_GPS_S = int(utc_to_gps_ns(np.datetime64("2025-01-01T00:00:00")) // NS_PER_S)
#: GPS - UTC in seconds at the default start (18 s since 2017-01-01), from the leap-second table.
GPS_MINUS_UTC_S = int(gps_minus_utc_s(DEFAULT_START_GPS_S * NS_PER_S))

#: gpsd TPV modes the simulated receiver reports: a time fix, or none.
_MODE_FIX, _MODE_NO_FIX = 3, 1


@dataclass(frozen=True)
class ReceiverTruth:
    """One run: the truth beside the receivers' reports, ``trials`` x ``receivers`` x ``epochs``.

    ``epochs`` (:class:`~chronofuse.epochs.ReceiverEpochs`) is what the receivers report. The truth,
    shape (trials, receivers, epochs) like it: ``pps_error_s`` (1PPS edge minus GNSS time, s, sawtooth
    included, NaN without a pulse; ``pps_error_s + epochs.qerr_s`` removes the sawtooth) and
    ``spoof_offset_s`` (the true drag-off, s). ``environment`` is the run's
    :class:`~chronofuse.models.environment.ReceiverEnvironment`. The arrays are held read-only.
    """

    rate_hz: float
    environment: ReceiverEnvironment
    epochs: ReceiverEpochs
    pps_error_s: np.ndarray
    spoof_offset_s: np.ndarray

    def __post_init__(self):
        if not isinstance(self.epochs, ReceiverEpochs):
            raise TypeError(f"epochs == {self.epochs!r}, must be a ReceiverEpochs")
        for name in ("pps_error_s", "spoof_offset_s"):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.shape != self.epochs.shape:
                raise ValueError(f"{name} has shape {value.shape}, must be {self.epochs.shape}")
            view = value.view()
            view.flags.writeable = False
            object.__setattr__(self, name, view)

    def record(self, source: str = "simulate_receivers") -> EpochRecord:
        """What the receivers report as the one epoch record (:meth:`ReceiverEpochs.to_record`, lead axes
        (trials, receivers)); the truth stays here."""
        return self.epochs.to_record(source)

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the run's start, shape (epochs,) (whole seconds: exact in float64)."""
        return ((self.epochs.gps_ns - self.epochs.gps_ns[0]) // NS_PER_S).astype(np.float64)

    def to_frame(self, trial: int = 0) -> pd.DataFrame:
        """Tidy table of one trial: one row per (receiver, epoch), nanoseconds in ``*_ns`` columns.

        Columns: t_s, receiver (1-based: receiver ``j`` of the arrays is ``j + 1``), pps_error_ns, qerr_ns,
        fix, n_sats, gdop, utc_s, leap_s, leap_pending, clock_bias_ns, gps_s, spoof_offset_ns; ``gps_s``
        and ``utc_s`` are whole seconds since the GPS epoch on each scale.
        """
        ep = self.epochs
        trials, receivers, steps = ep.shape
        check_scalar(trial, "trial", min_val=0, max_val=trials - 1, integer=True)
        i = int(trial)

        def flat(a: np.ndarray) -> np.ndarray:
            return a[i].reshape(-1)

        return pd.DataFrame({
            "t_s": np.tile(self.t_s, receivers),
            "receiver": np.repeat(np.arange(1, receivers + 1), steps),  # 1-based, as every report names them
            "pps_error_ns": flat(self.pps_error_s) * 1e9,
            "qerr_ns": flat(ep.qerr_s) * 1e9,
            "fix": flat(ep.has_fix),
            "n_sats": flat(ep.n_sats),
            "gdop": flat(ep.gdop),
            "utc_s": flat(ep.utc_ns()) // NS_PER_S,
            "leap_s": flat(ep.leap_s),
            "leap_pending": flat(ep.leap_pending),
            "clock_bias_ns": flat(ep.clock_bias_s) * 1e9,
            "gps_s": np.tile(ep.gps_ns // NS_PER_S, receivers),
            "spoof_offset_ns": flat(self.spoof_offset_s) * 1e9,
        })


#: The random numbers of one (trial, receiver) stream, drawn in this order whatever the model (so that
#: two environments run with one seed share their noise): name, law, extra length beyond ``steps``.
_STREAM_LAYOUT = (
    ("white", "normal", 0),
    ("multipath", "normal", 1),
    ("wander", "normal", 1),
    ("geometry", "normal", 1),
    ("outlier_u", "uniform", 0),
    ("outlier_n", "normal", 0),
    ("jump_u", "uniform", 0),
    ("jump_n", "normal", 0),
    ("outage_u", "uniform", 0),
    ("outage_len", "geometric", 0),
    ("nofix_sats", "sats", 0),
    ("clock_wfm", "normal", 0),
    ("clock_rwfm", "normal", 0),
    ("clock_rwfm_phase", "normal", 0),
    ("clock_const", "uniform", None),  # 3 numbers: frequency offset, initial bias, tick phase
)


def _draw(root: np.random.SeedSequence, trials: int, receivers: int, steps: int,
          outage_mean_steps: float, first_trial: int = 0) -> dict[str, np.ndarray]:
    """Every stream's random numbers, each of shape (trials, receivers, length), filled in place."""
    draw = {}
    for name, law, extra in _STREAM_LAYOUT:
        length = 3 if extra is None else steps + extra
        draw[name] = np.empty((trials, receivers, length), dtype=np.int64 if law in ("geometric", "sats") else np.float64)
    p_geometric = min(1.0, 1.0 / outage_mean_steps)
    for i in range(trials):
        for j in range(receivers):
            rng = child_rng(root, first_trial + i, j)
            for name, law, _ in _STREAM_LAYOUT:
                out = draw[name][i, j]
                if law == "normal":
                    rng.standard_normal(out=out)
                elif law == "uniform":
                    rng.random(out=out)
                elif law == "geometric":
                    out[:] = rng.geometric(p_geometric, out.shape[0])
                else:
                    out[:] = rng.integers(0, 4, out.shape[0])
    return draw


def _intervals_mask(start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """True inside ``[k, k + length[k])`` for every ``k`` with ``start[k]``, along the last axis."""
    steps = start.shape[-1]
    flat = start.reshape(-1, steps)
    lengths = length.reshape(-1, steps)
    rows, cols = np.nonzero(flat)
    edges = np.zeros((flat.shape[0], steps + 1), dtype=np.int64)
    np.add.at(edges, (rows, cols), 1)
    np.add.at(edges, (rows, np.minimum(cols + lengths[rows, cols], steps)), -1)
    return (np.cumsum(edges[:, :steps], axis=1) > 0).reshape(start.shape)


def _solution_error(model: ReceiverModel, draw: dict[str, np.ndarray], geometry_gain, dt: float) -> np.ndarray:
    """Timing error ``e`` of the navigation solution, shape (trials, receivers, steps), seconds.

    Consumes (pops) its entries of ``draw`` to free memory early.
    """
    error = model.white_sigma_s * geometry_gain * draw.pop("white")
    error += gauss_markov(draw.pop("multipath"), model.multipath_sigma_s, model.multipath_tau_s, dt)
    error += gauss_markov(draw.pop("wander"), model.wander_sigma_s, model.wander_tau_s, dt)
    error += np.where(draw.pop("outlier_u") < model.outlier_prob, model.outlier_sigma_s * draw.pop("outlier_n"), 0.0)
    p_jump = 1.0 - (1.0 - model.jump_prob) ** dt
    error += np.cumsum(np.where(draw.pop("jump_u") < p_jump, model.jump_sigma_s * draw.pop("jump_n"), 0.0), axis=-1)
    return error


def _oscillator_bias_s(model: ReceiverModel, draw: dict[str, np.ndarray], t_s: np.ndarray, dt: float) -> np.ndarray:
    """True bias ``b`` of the free-running receiver oscillator, shape (trials, receivers, steps), seconds.

    ``b = b0 + y0 t`` plus white FM and random-walk FM, sampled exactly by
    :func:`~chronofuse.models.clock.two_state_clock_phase_s`, so that its second difference has the
    autocorrelation the HOD detector assumes. Pops its noise entries of ``draw``.
    """
    const = draw["clock_const"]
    y0 = model.clock_freq_offset_max * (2.0 * const[..., 0] - 1.0)
    b0 = model.clock_initial_bias_max_s * (2.0 * const[..., 1] - 1.0)
    noise = two_state_clock_phase_s(draw.pop("clock_wfm"), draw.pop("clock_rwfm"), draw.pop("clock_rwfm_phase"),
                                    h0=model.clock_h0, hm2=model.clock_hm2, dt_s=dt)
    return b0[..., None] + y0[..., None] * t_s + noise


def sawtooth_s(bias_hat_s: np.ndarray, tick_phase: np.ndarray, tick_hz: float, dt_s: float) -> np.ndarray:
    """Quantization error ``q`` of 1PPS edges placed on the nearest receiver-clock tick, seconds.

    ``bias_hat_s`` (trials, receivers, steps): the receiver's estimate of its clock bias at pulse ``k``
    (taken at ``t_k = k dt_s``); ``tick_phase`` (trials, receivers): ticks sit at local times
    ``(tick_phase + n) / tick_hz``. With ``u = t_k tick_hz + bias_hat tick_hz - tick_phase``,
    ``q = (round(u) - u) / tick_hz`` lies in ``[-T/2, T/2]``. ``t_k tick_hz`` is reduced modulo 1 in
    integer steps so that long runs keep the precision of a tick.
    """
    steps = bias_hat_s.shape[-1]
    step_frac = np.mod(dt_s * tick_hz, 1.0)
    u = np.mod(np.arange(steps) * step_frac, 1.0) + bias_hat_s * tick_hz - tick_phase[..., None]
    return (np.rint(u) - u) / tick_hz


def _epoch_grid(duration_s: int, rate_hz: float, start_gps_s: int) -> tuple[int, np.ndarray]:
    """The pulse period (whole seconds) and the GPS seconds of the pulses (steps,) int64."""
    check_scalar(duration_s, "duration_s", min_val=1, integer=True)
    check_scalar(rate_hz, "rate_hz", min_val=0.0, max_val=1.0, include_min=False)
    period_s = int(round(1.0 / rate_hz))
    if abs(period_s * rate_hz - 1.0) > 1e-9:
        raise InputError(f"{{rate_hz}} == {rate_hz}, must be 1 / (whole number of seconds)", fields=("rate_hz",))
    check_scalar(start_gps_s, "start_gps_s", min_val=0, integer=True)
    steps = int(duration_s) // period_s
    if steps < 1:
        raise InputError(f"{{duration_s}} == {duration_s}, must hold at least one pulse at {{rate_hz}} == {rate_hz}",
                         fields=("duration_s", "rate_hz"))
    return period_s, np.int64(start_gps_s) + np.arange(steps, dtype=np.int64) * period_s


def _leap_schedule(gps_s: np.ndarray, leap_s: int, leap_event_gps_s: int | None,
                   leap_announce_s: int) -> tuple[np.ndarray, np.ndarray]:
    """GPS - UTC (s) and the pending-leap flag (+1 within ``leap_announce_s`` before an inserted leap
    second, else 0) at each pulse, both (steps,)."""
    check_scalar(leap_s, "leap_s", integer=True)
    check_scalar(leap_announce_s, "leap_announce_s", min_val=0, integer=True)
    leap = np.full(gps_s.shape, int(leap_s), dtype=np.int64)
    pending = np.zeros(gps_s.shape, dtype=np.int8)
    if leap_event_gps_s is not None:
        check_scalar(leap_event_gps_s, "leap_event_gps_s", min_val=0, integer=True)
        leap[gps_s >= leap_event_gps_s] += 1
        pending[(gps_s < leap_event_gps_s) & (gps_s >= leap_event_gps_s - leap_announce_s)] = 1
    return leap, pending


def _geometry(model: ReceiverModel, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """GDOP (log-normal) and satellites used (int64) from the unit Gauss-Markov latent ``z``."""
    gdop = np.maximum(1.0, model.gdop_median * np.exp(model.gdop_log_sigma * z))
    n_sats = np.clip(np.rint(model.n_sats_median - model.n_sats_spread * z), 4, model.n_sats_max).astype(np.int64)
    return gdop, n_sats


def simulate_receivers(
    environment: str | ReceiverEnvironment,
    duration_s: int,
    n_receivers: int,
    seed: SeedLike,
    trials: int = 1,
    *,
    rate_hz: float = 1.0,
    start_gps_s: int = DEFAULT_START_GPS_S,
    leap_s: int = GPS_MINUS_UTC_S,
    leap_event_gps_s: int | None = None,
    leap_announce_s: int = 86_400,
    first_trial: int = 0,
) -> ReceiverTruth:
    """Simulate ``n_receivers`` receivers at one site, independent errors, ``trials`` times.

    Parameters
    ----------
    environment : a name in :data:`~chronofuse.models.environment.ENVIRONMENTS` or a ReceiverEnvironment.
    duration_s : run length in whole seconds; ``steps = duration_s * rate_hz``.
    n_receivers, trials : sizes of the first two axes of the result.
    seed : int or SeedSequence (reproduces) or Generator (consumed), :func:`chronofuse.seeding.root_seed`;
        stream ``(i, j)`` (trial ``i``, receiver ``j``) is seeded by ``root.spawn(trials)[i].spawn(n_receivers)[j]``
        of a fresh root, i.e. the child with spawn key ``root.spawn_key + (i, j)``, so it does not depend
        on how many trials or receivers ran.
    rate_hz : pulses kept per second; ``1 / rate_hz`` must be a whole number of seconds (1, 0.5, 0.1...).
    start_gps_s : GPS seconds of the first pulse (default 2025-01-01T00:00:00 UTC).
    leap_s : GPS - UTC at the start (s).
    leap_event_gps_s : first GPS second with ``leap_s + 1`` (a positive leap second); ``None``: none.
    leap_announce_s : ``leap_pending`` is +1 this long before the event.
    first_trial : the first trial's index ``i`` in the seeding above: the result's trial ``t`` is trial
        ``first_trial + t`` of a larger run (the same numbers), so a run can be simulated in blocks of trials.

    Returns
    -------
    ReceiverTruth whose arrays, and its ``epochs``, have shape (trials, n_receivers, steps).
    """
    env = receiver_environment(environment) if isinstance(environment, str) else environment
    if not isinstance(env, ReceiverEnvironment):
        raise TypeError(f"environment == {environment!r}, must be an environment name or a ReceiverEnvironment")
    model = env.model
    check_scalar(n_receivers, "n_receivers", min_val=1, integer=True)
    check_scalar(trials, "trials", min_val=1, integer=True)
    check_scalar(first_trial, "first_trial", min_val=0, integer=True)
    period_s, gps_s = _epoch_grid(duration_s, rate_hz, start_gps_s)
    leap, pending = _leap_schedule(gps_s, leap_s, leap_event_gps_s, leap_announce_s)
    affected = env.affected_mask(n_receivers)
    steps, dt = gps_s.size, float(period_s)
    t_s = (gps_s - gps_s[0]).astype(np.float64)
    shape = (int(trials), int(n_receivers), steps)

    # Random numbers: one SeedSequence child per (trial, receiver).
    draw = _draw(root_seed(seed), shape[0], shape[1], steps, model.outage_mean_s / dt, int(first_trial))
    gdop, n_sats = _geometry(model, gauss_markov(draw.pop("geometry"), 1.0, model.gdop_tau_s, dt))
    error = _solution_error(model, draw, gdop / model.gdop_median, dt)

    # Events.
    spoof = np.broadcast_to(np.where(affected[:, None], env.spoof_offset_s(t_s)[None, :], 0.0), shape).copy()
    jammed = np.broadcast_to(affected[:, None] & env.jammed(t_s)[None, :], shape)
    p_outage = 1.0 - np.exp(-model.outage_rate_hz * dt)
    outage = _intervals_mask(draw.pop("outage_u") < p_outage, draw.pop("outage_len"))
    fix = ~outage & ~jammed & (gdop <= model.gdop_fix_max)

    bias_hat = _oscillator_bias_s(model, draw, t_s, dt) + error + spoof
    sawtooth = sawtooth_s(bias_hat, draw["clock_const"][..., 2], model.tick_hz, dt)
    qerr = -np.round(sawtooth * 1e12) * 1e-12

    nan = np.float64(np.nan)
    absent = ReceiverEpochs.absent(gps_s * NS_PER_S, shape[0], shape[1], leap_s=leap)
    epochs = ReceiverEpochs(**{
        **absent,
        "fix_mode": np.where(fix, _MODE_FIX, _MODE_NO_FIX).astype(np.int8),
        "time_valid": fix,
        "n_sats": np.where(fix, n_sats, np.where(jammed, 0, draw["nofix_sats"])),
        "gdop": np.where(fix, gdop, nan),
        "leap_pending": np.broadcast_to(pending, shape),
        "qerr_s": np.where(fix, qerr, nan),
        "clock_bias_s": np.where(fix, bias_hat, nan),
    })
    return ReceiverTruth(
        rate_hz=float(rate_hz),
        environment=env,
        epochs=epochs,
        pps_error_s=np.where(fix, error + spoof + sawtooth, nan),
        spoof_offset_s=spoof,
    )
