"""Sync algorithms by name: :data:`SYNC`, the family's registry on the shared mechanism (:mod:`chronofuse.registry`).

Each member is a class and a configuration (a :class:`~chronofuse.registry.Config` whose fields carry their
units). :func:`make_algorithm` builds an unfitted algorithm for a node that knows :class:`LinkKnowledge`
(its link model, both clocks' oscillator, the link's prior and its URT calibration): every setting the
caller does not give is taken from that knowledge, and a setting given is validated by the configuration
(a bad one is refused by name). Adding an algorithm is one module and one :data:`SYNC` entry; a plugin adds
one through the entry-point group ``chronofuse.sync`` (its :class:`~chronofuse.registry.Entry` builds the
member from ``context["knowledge"]``).

=================== =========================================================================================
null                the do-nothing baseline (estimate 0; linuxptp's ``nullf``)
ptp-pi              IEEE 1588 offset (per-exchange delay) through linuxptp's PI servo
ptp-pi-median       the same with linuxptp's 10-sample moving-median delay filter
ptp-linreg          PTP offsets through linuxptp's linear-regression servo
ptp-chrony          PTP offsets through a chrony-style runs-test regression
ptp-mls             PTP offsets smoothed by moving least squares (32 exchanges)
rtt-rvc             the paper's eq. (9) per exchange with the Doppler velocity (its ref. [28])
rtt-rvc-kf          the paper's chain: RVC -> URT -> KF [eps, eps_dot, v] with H = [1 0 0]
rtt-rvc-kf-bp       the same with its BP 9-32-1 residual network (the paper's proposed algorithm)
rtt-rvc-kf-lstm     the same with the LSTM residual baseline (the paper's section 4.6)
rtt-rvc-kf-numba    rtt-rvc-kf through one numba kernel (a node's real-time step)
rtt-rvc-kf-bp-numba rtt-rvc-kf-bp through that kernel
doppler-kf          the complete-model filter: every term of the exchange, flicker FM, the prior, the
                    calibration's uncertainty, a node state and the URT monitor (:mod:`chronofuse.sync.doppler`)
=================== =========================================================================================

Names used before these (``proposed``, ``proposed-no-nn``, ``lstm``, ``ours-doppler``, ``ours-accel``,
``ptp``, ``ptp-median``, ``proposed-fast``) are refused with the new name in the message
(:data:`RENAMED`), so an old command fails loudly instead of running something else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from chronofuse.models.clock_markov import ClockMarkovModel
from chronofuse.models.link import LinkModel
from chronofuse.models.oscillator import OscillatorModel
from chronofuse.models.oscillator_presets import preset
from chronofuse.registry import Config, Entry, Registry
from chronofuse.sync.base import NullSync, SyncAlgorithm
from chronofuse.sync.chain import RvcKfChain, RvcKfConfig
from chronofuse.sync.doppler import DopplerKf, DopplerKfConfig
from chronofuse.sync.fast import FastRvcKfChain
from chronofuse.sync.mls import PtpMls
from chronofuse.sync.prior import LinkPrior
from chronofuse.sync.ptp import PtpPiServo
from chronofuse.sync.regression import ChronyRegression, PtpLinreg
from chronofuse.sync.rvc import RttRvc
from chronofuse.validation import InputError

__all__ = ["LinkKnowledge", "SYNC", "ALGORITHM_NAMES", "NEEDS_NETWORK", "RENAMED", "make_algorithm", "check_name"]


@dataclass(frozen=True)
class LinkKnowledge:
    """What a node on a link knows: ``link`` (its noise model, exchange interval, reply slot), ``oscillator``
    (both clocks' model), ``prior`` (:class:`~chronofuse.sync.prior.LinkPrior`), ``steps`` (exchanges in the
    run), ``urt_s`` and ``calibration_sigma_s`` (the calibrated fixed URT and its 1-sigma, s; scalars or one
    per trial), ``urt_mode`` ("calibrated", or "paper" for the paper's batch URT estimate)."""

    link: LinkModel = LinkModel()
    oscillator: OscillatorModel | None = None
    prior: LinkPrior = LinkPrior()
    steps: int = 2000
    urt_s: float | np.ndarray = 20e-9
    calibration_sigma_s: float | np.ndarray = 0.0
    urt_mode: str = "calibrated"

    @property
    def clock_oscillator(self) -> OscillatorModel:
        return preset("ocxo") if self.oscillator is None else self.oscillator

    def clock_model(self) -> ClockMarkovModel:
        """The two clocks' offset as the filters and the bound model it (flicker FM included)."""
        osc = self.clock_oscillator
        return ClockMarkovModel.for_link(osc, osc, self.link.interval_s, self.steps * self.link.interval_s)


class NullConfig(Config):
    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")


class PtpPiConfig(Config):
    """linuxptp's PI servo (:mod:`chronofuse.sync.ptp`)."""

    interval_s: float = Field(0.01, gt=0.0, description="exchange (sync) interval (s)")
    delay_filter: str = Field("per-exchange", pattern="^(per-exchange|median)$", description="delay filter (choice)")
    delay_filter_length: int = Field(10, ge=1, description="moving-median length (exchanges)")
    kp_scale: float = Field(0.7, ge=0.0, description="pi_proportional_scale (dimensionless)")
    ki_scale: float = Field(0.3, gt=0.0, description="pi_integral_scale (dimensionless)")
    first_step_threshold_s: float = Field(20e-6, ge=0.0, description="first step threshold (s)")
    max_frequency: float = Field(1e-4, gt=0.0, description="largest frequency adjustment (fractional)")


class PtpLinregConfig(Config):
    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")
    first_step_threshold_s: float = Field(20e-6, ge=0.0, description="first step threshold (s)")
    max_frequency: float = Field(1e-4, gt=0.0, description="largest frequency adjustment (fractional)")


class PtpMlsConfig(Config):
    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")
    window: int = Field(32, ge=16, le=64, description="moving least-squares window (exchanges)")


class RttRvcConfig(Config):
    interval_s: float = Field(0.01, gt=0.0, description="exchange interval (s)")
    light_time: str = Field("paper", pattern="^(paper|exact)$", description="the paper's eq. (9) or exact (choice)")


def _interval(k: LinkKnowledge) -> dict:
    return {"interval_s": k.link.interval_s}


def _chain(k: LinkKnowledge) -> dict:
    osc = k.clock_oscillator
    urt = k.urt_s if np.ndim(k.urt_s) == 0 else tuple(float(v) for v in np.ravel(k.urt_s))
    return dict(interval_s=k.link.interval_s, urt_mode=k.urt_mode, urt_s=urt, toa_sigma_s=k.link.toa_sigma_s,
                urt_jitter_s=k.link.urt_jitter_s, velocity_sigma_m_s=k.link.velocity_sigma_m_s,
                reply_delay_s=k.link.reply_delay_s, snr_db=k.link.snr_db, h0_s=2.0 * osc.h.h0,
                hm2_per_s=2.0 * osc.h.hm2, steps=k.steps)


def _doppler(k: LinkKnowledge) -> dict:
    cfg = DopplerKfConfig.from_models(k.link, k.clock_model(), k.prior, k.urt_s, k.calibration_sigma_s)
    return {name: getattr(cfg, name) for name in type(cfg).model_fields}


def _builder(cls, defaults, network: str | None = None, *, takes_config: bool = True):
    """``build(config, context)``: the settings the caller gave, the rest from ``context["knowledge"]``."""

    def build(config: Config, context) -> SyncAlgorithm:
        knowledge = context.get("knowledge") or LinkKnowledge()
        given = {name: getattr(config, name) for name in config.model_fields_set}
        full = type(config)(**{**defaults(knowledge), **given})
        if not takes_config:
            return cls(**full.settings())
        net = None
        if network is not None:
            net = (context.get("networks") or {}).get(network)
            if net is None:
                raise InputError(f"{{algorithm}} == {context.get('name')!r} needs a trained {network} network "
                                 "(experiments.swarm_training.train_networks writes one)", fields=("algorithm",))
            want = {"light_time": full.light_time, "urt_mode": full.urt_mode}
            if dict(net.config.chain) != want:
                raise InputError(f"{{algorithm}} == {context.get('name')!r}: its network was trained behind chain "
                                 f"{net.config.chain}, this run is {want}", fields=("algorithm",))
        return cls(full, residual_model=net) if cls in (RvcKfChain, FastRvcKfChain) else cls(full)

    return build


SYNC = Registry("sync")
for _name, _cls, _config, _defaults, _net, _takes, _summary in (
    ("null", NullSync, NullConfig, _interval, None, False, "the do-nothing baseline"),
    ("ptp-pi", PtpPiServo, PtpPiConfig, _interval, None, False, "IEEE 1588 offsets, linuxptp PI servo"),
    ("ptp-pi-median", PtpPiServo, PtpPiConfig, lambda k: {**_interval(k), "delay_filter": "median"}, None, False,
     "the same with linuxptp's moving-median delay filter"),
    ("ptp-linreg", PtpLinreg, PtpLinregConfig, _interval, None, False, "linuxptp's linear-regression servo"),
    ("ptp-chrony", ChronyRegression, NullConfig, _interval, None, False, "chrony-style runs-test regression"),
    ("ptp-mls", PtpMls, PtpMlsConfig, _interval, None, False, "PTP offsets, moving least squares"),
    ("rtt-rvc", RttRvc, RttRvcConfig, _interval, None, False, "the paper's eq. (9) per exchange"),
    ("rtt-rvc-kf", RvcKfChain, RvcKfConfig, _chain, None, True, "the paper's chain without its network"),
    ("rtt-rvc-kf-bp", RvcKfChain, RvcKfConfig, _chain, "bp", True, "the paper's chain with its BP network"),
    ("rtt-rvc-kf-lstm", RvcKfChain, RvcKfConfig, _chain, "lstm", True, "the paper's chain with an LSTM"),
    ("rtt-rvc-kf-numba", FastRvcKfChain, RvcKfConfig, _chain, None, True, "rtt-rvc-kf in one numba kernel"),
    ("rtt-rvc-kf-bp-numba", FastRvcKfChain, RvcKfConfig, _chain, "bp", True, "rtt-rvc-kf-bp in one numba kernel"),
    ("doppler-kf", DopplerKf, DopplerKfConfig, _doppler, None, True, "the complete-model filter"),
):
    SYNC.add(_name, Entry(_cls, _config, _summary, _builder(_cls, _defaults, _net, takes_config=_takes)))

ALGORITHM_NAMES = SYNC.builtin_names()
#: The built-in algorithms that need a trained residual network, and which one.
NEEDS_NETWORK = {"rtt-rvc-kf-bp": "bp", "rtt-rvc-kf-lstm": "lstm", "rtt-rvc-kf-bp-numba": "bp"}
#: Names used before, and what they are called now (None: gone, with the reason).
RENAMED = {
    "proposed": "rtt-rvc-kf-bp", "proposed-no-nn": "rtt-rvc-kf", "lstm": "rtt-rvc-kf-lstm",
    "ours-doppler": "doppler-kf", "ptp": "ptp-pi", "ptp-median": "ptp-pi-median", "proposed-fast": "rtt-rvc-kf-numba",
    "ours-accel": None,
}
_GONE = {"ours-accel": "doppler-kf takes the Doppler velocity at every exchange, so no velocity state lags a "
                       "manoeuvre and the acceleration state is not needed"}


def check_name(name: str) -> str:
    """``name`` if registered (a plugin's too); else InputError, with the new name of a renamed algorithm."""
    if name in SYNC:
        return name
    if name in RENAMED:
        new = RENAMED[name]
        hint = f"it is now called {new!r}" if new else f"it was removed: {_GONE[name]}"
        raise InputError(f"{{algorithm}} == {name!r}: {hint}", fields=("algorithm",))
    raise InputError(f"{{algorithm}} == {name!r}, must be one of {list(SYNC.names())}", fields=("algorithm",))


def make_algorithm(name: str, knowledge: LinkKnowledge | None = None, *, networks: dict | None = None,
                   **overrides) -> SyncAlgorithm:
    """The unfitted algorithm ``name`` for a node that knows ``knowledge`` (default: the paper's link).

    ``overrides`` replace fields of its configuration (validated by it); ``networks`` maps "bp" / "lstm"
    to trained residual networks for the algorithms that need one.
    """
    check_name(name)
    context = {"knowledge": LinkKnowledge() if knowledge is None else knowledge, "networks": networks, "name": name}
    return SYNC.create(name, context=context, **overrides)
