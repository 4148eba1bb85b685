"""Sync algorithms by name, configured from the link and oscillator models (the engine-registry shape).

Each entry builds an unfitted algorithm from the :class:`~chronofuse.models.link.LinkModel` the receiver
runs (its exchange interval, reply delay, SNR and therefore its TOA and Doppler noise), the oscillator
model of both nodes (the clock process noise) and the URT mode. What each name means:

============== ===============================================================================
null           the do-nothing baseline (estimate 0)
ptp            IEEE 1588 offset (per-exchange delay) through linuxptp's PI servo
ptp-median     the same with linuxptp's 10-sample moving-median delay filter
ptp-linreg     PTP offsets through linuxptp's linear-regression servo
ptp-chrony     PTP offsets through a chrony-style runs-test regression
ptp-mls        PTP offsets smoothed by moving least squares (32 exchanges)
rtt-rvc        seed eq. (9) per exchange with the Doppler velocity
proposed       the seed's chain: RVC -> URT -> KF [eps, eps_dot, v], H = [1 0 0] -> BP 9-32-1 residual
proposed-no-nn the same chain without its network (the ablation)
lstm           the same chain with the LSTM residual baseline instead of the BP network
ours-doppler   exact-light-time RVC -> URT -> KF observing the Doppler velocity
ours-accel     the same with an acceleration state
============== ===============================================================================
"""

from __future__ import annotations

from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator import OscillatorModel
from chronofuse.models.oscillator_presets import preset
from chronofuse.sync.base import NullSync, SyncAlgorithm
from chronofuse.sync.chain import ProposedChain
from chronofuse.sync.mls import PtpMls
from chronofuse.sync.ptp import PtpPiServo
from chronofuse.sync.regression import ChronyRegression, PtpLinreg
from chronofuse.sync.rvc import RttRvc
from chronofuse.validation import InputError, check_choice

__all__ = ["ALGORITHM_NAMES", "NEEDS_NETWORK", "make_algorithm", "chain_noise"]

ALGORITHM_NAMES = ("null", "ptp", "ptp-median", "ptp-linreg", "ptp-chrony", "ptp-mls", "rtt-rvc", "proposed", "proposed-no-nn", "lstm", "ours-doppler",
                   "ours-accel")
#: The algorithms that need a trained residual network, and which one.
NEEDS_NETWORK = {"proposed": "bp", "lstm": "lstm"}


def chain_noise(link: LinkModel, oscillator: OscillatorModel, steps: int) -> dict:
    """The keyword arguments of :class:`ProposedChain` that describe the link and the two clocks."""
    return dict(toa_sigma_s=link.toa_sigma_s, urt_jitter_s=link.urt_jitter_s,
                velocity_sigma_m_s=link.velocity_sigma_m_s, reply_delay_s=link.reply_delay_s, snr_db=link.snr_db,
                h0=2.0 * oscillator.h.h0, hm2=2.0 * oscillator.h.hm2, steps=steps, interval_s=link.interval_s)


def make_algorithm(name: str, link: LinkModel, *, steps: int = 2000, urt_mode: str = "paper",
                   urt_fixed_s: float = 0.0, oscillator: OscillatorModel | None = None,
                   networks: dict | None = None) -> SyncAlgorithm:
    """The unfitted algorithm ``name`` (one of :data:`ALGORITHM_NAMES`) for ``link``.

    ``urt_mode`` and ``urt_fixed_s`` (the calibrated fixed URT, s) configure the chains' URT stage;
    ``oscillator`` (default: the OCXO preset) gives both clocks' process noise; ``networks`` maps
    "bp" / "lstm" to trained residual networks for "proposed" and "lstm".
    """
    check_choice(name, "algorithm", ALGORITHM_NAMES)
    osc = preset("ocxo") if oscillator is None else oscillator
    dt = link.interval_s
    if name == "null":
        return NullSync(interval_s=dt)
    if name == "ptp":
        return PtpPiServo(interval_s=dt)
    if name == "ptp-median":
        return PtpPiServo(delay_filter="median", interval_s=dt)
    if name == "ptp-linreg":
        return PtpLinreg(interval_s=dt)
    if name == "ptp-chrony":
        return ChronyRegression(interval_s=dt)
    if name == "ptp-mls":
        return PtpMls(interval_s=dt)
    if name == "rtt-rvc":
        return RttRvc(interval_s=dt)
    noise = chain_noise(link, osc, steps)
    if name in ("proposed", "proposed-no-nn", "lstm"):
        net = None
        if name in NEEDS_NETWORK:
            net = (networks or {}).get(NEEDS_NETWORK[name])
            if net is None:
                raise InputError(f"{{algorithm}} == {name!r} needs a trained {NEEDS_NETWORK[name]} network "
                                 "(chronofuse swarm train writes one)", fields=("algorithm",))
            want = {"filter": "seed", "light_time": "seed", "urt_mode": urt_mode}
            if dict(net.config.chain) != want:
                raise InputError(f"{{algorithm}} == {name!r}: its network was trained behind chain {net.config.chain}, "
                                 f"this run is {want}", fields=("algorithm",))
        return ProposedChain(filter="seed", light_time="seed", urt_mode=urt_mode, urt_fixed_s=urt_fixed_s,
                             residual_model=net, **noise)
    filt = "doppler" if name == "ours-doppler" else "doppler-accel"
    return ProposedChain(filter=filt, light_time="exact", urt_mode=urt_mode, urt_fixed_s=urt_fixed_s, **noise)
