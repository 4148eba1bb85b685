"""Two-node link experiments of seed 001 (orchestration only): scenario -> truth -> algorithms -> metrics.

:func:`run_link` is the one library call behind ``chronofuse swarm run`` (and what the main job can
call): it simulates a scenario, runs each named algorithm, and returns per-algorithm RMSE,
convergence epochs and the PCRB under the same link model.

Random streams (``chronofuse.seeding``): clock A ``child_seed(root, 0)``, clock B ``child_seed(root, 1)``,
link noise ``child_seed(root, 2)``; inside each, trial ``i`` has its own child, so a trial's numbers do
not depend on how many trials run or where.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from chronofuse.models.kinematics import radial_geometry
from chronofuse.models.link import Exchanges, LinkModel, node_clock_error_s, simulate_exchanges
from chronofuse.models.oscillator import preset
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.metrics import convergence_epochs, rmse_s
from chronofuse.sync.pcrb import link_pcrb
from chronofuse.sync.registry import ALGORITHM_NAMES, make_algorithm
from chronofuse.sync.rvc import rvc_offset_exact_s
from chronofuse.sync.urt import calibrate_urt
from chronofuse.validation import check_choice, check_scalar

__all__ = ["LinkScenario", "simulate_scenario", "calibrated_urt_s", "run_link"]


@dataclass(frozen=True)
class LinkScenario:
    """One two-node link run (defaults: seed 001 section 4, SNR 10 dB assumed; the seed does not say).

    Attributes: ``distance_m`` (initial range, >= 0), ``velocity_m_s`` (radial, opening > 0),
    ``acceleration_m_s2`` (radial), ``exchanges``, ``true_offset_s`` (B minus A at the start),
    ``true_skew`` (fractional frequency of B minus A), ``oscillator`` (preset of both clocks), and the
    :class:`~chronofuse.models.link.LinkModel` ``link``.
    """

    distance_m: float = 80e3
    velocity_m_s: float = 800.0
    acceleration_m_s2: float = 0.0
    exchanges: int = 2000
    true_offset_s: float = 0.0
    true_skew: float = 0.0
    oscillator: str = "ocxo"
    link: LinkModel = LinkModel()

    def __post_init__(self):
        check_scalar(self.distance_m, "distance", min_val=0.0)
        check_scalar(self.velocity_m_s, "velocity", min_val=-1e5, max_val=1e5)
        check_scalar(self.acceleration_m_s2, "acceleration_m_s2")
        check_scalar(self.exchanges, "exchanges", min_val=2, integer=True)
        check_scalar(self.true_offset_s, "true_offset")
        check_scalar(self.true_skew, "true_skew", min_val=-1e-3, max_val=1e-3)
        preset(self.oscillator)
        if not isinstance(self.link, LinkModel):
            raise TypeError(f"link == {self.link!r}, must be a LinkModel")


def simulate_scenario(scenario: LinkScenario, trials: int, seed) -> Exchanges:
    """Truth and measurements of ``trials`` runs of ``scenario``."""
    check_scalar(trials, "trials", min_val=1, integer=True)
    base = root_seed(seed)
    osc = preset(scenario.oscillator)
    steps, dt = int(scenario.exchanges), scenario.link.interval_s
    xa = node_clock_error_s(osc, steps, dt, child_seed(base, 0), int(trials))
    xb = node_clock_error_s(osc, steps, dt, child_seed(base, 1), int(trials), offset_s=scenario.true_offset_s,
                            frequency_offset=scenario.true_skew)
    a, b = radial_geometry(scenario.distance_m, scenario.velocity_m_s, scenario.acceleration_m_s2)
    return simulate_exchanges(a, b, xa, xb, scenario.link, steps, child_seed(base, 2))


def calibrated_urt_s(scenario: LinkScenario, seed, trials: int = 4, exchanges: int = 6000,
                     gnss_sigma_s: float = 5e-9) -> float:
    """The calibrated mode's fixed URT, s: learnt on a separate run of ``exchanges`` while both nodes
    know true time through GNSS (each with white timing error ``gnss_sigma_s``), then kept.

    Uses the truth on purpose (the supervised calibration step of SPEC 5).
    """
    base = root_seed(seed)
    calib = replace(scenario, exchanges=exchanges)
    ex = simulate_scenario(calib, trials, child_seed(base, 0))
    rng = np.random.default_rng(child_seed(base, 1))
    gnss = ex.offset_s + gnss_sigma_s * np.sqrt(2.0) * rng.standard_normal(ex.offset_s.shape)
    eps = rvc_offset_exact_s(ex.t_i_s, ex.t_b_s, ex.t_r_s, ex.velocity_m_s)
    return float(np.mean(calibrate_urt(eps, gnss, ex.velocity_m_s)))


def run_link(scenario: LinkScenario, algorithms=ALGORITHM_NAMES, *, trials: int = 20, seed=0,
             urt_mode: str = "calibrated", threshold_s: float = 1e-9) -> dict:
    """Run ``algorithms`` on ``trials`` simulated runs of ``scenario``.

    Returns a dict: ``rmse_s`` and ``convergence_epochs`` per algorithm (K*: first exchange whose
    running RMSE over trials is <= ``threshold_s``, seed eq. 48; None if never), ``pcrb_s`` (the PCRB of the
    offset at the last exchange and its RMS over the run), ``urt_fixed_estimate_s`` (calibrated mode),
    the scenario and the settings.
    """
    check_choice(urt_mode, "urt_mode", ("paper", "calibrated"))
    base = root_seed(seed)
    ex = simulate_scenario(scenario, trials, child_seed(base, 0))
    Z = measurement_array(ex)
    tp = calibrated_urt_s(scenario, child_seed(base, 1)) if urt_mode == "calibrated" else 0.0
    rmse, conv = {}, {}
    for name in algorithms:
        alg = make_algorithm(name, scenario.link, steps=scenario.exchanges, urt_mode=urt_mode, urt_fixed_s=tp,
                             oscillator=preset(scenario.oscillator)).fit()
        err = alg.run(Z).offset_s - ex.offset_s
        rmse[name] = rmse_s(err)
        conv[name] = convergence_epochs(err, threshold_s)
    bound = link_pcrb(scenario.link, preset(scenario.oscillator), scenario.exchanges, scenario.distance_m,
                      scenario.velocity_m_s)
    return {
        "rmse_s": rmse,
        "convergence_epochs": conv,
        "pcrb_s": {"final": float(np.sqrt(bound.offset_var_s2[-1])),
                   "rms": float(np.sqrt(np.mean(bound.offset_var_s2)))},
        "urt_fixed_estimate_s": tp,
        "urt_mode": urt_mode,
        "threshold_s": float(threshold_s),
        "trials": int(trials),
        "scenario": {k: v for k, v in asdict(scenario).items() if k != "link"} | {"link": asdict(scenario.link)},
    }
