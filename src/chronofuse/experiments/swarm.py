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
from chronofuse.models.oscillator_presets import preset
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.metrics import convergence_epochs, rmse_s, robustness
from chronofuse.sync.pcrb import link_pcrb
from chronofuse.sync.registry import ALGORITHM_NAMES, make_algorithm
from chronofuse.sync.rvc import rvc_offset_exact_s
from chronofuse.sync.urt import calibrate_urt
from chronofuse.validation import InputError, check_choice, check_scalar

__all__ = ["LinkScenario", "simulate_scenario", "calibrated_urt_s", "run_link", "residual_dataset", "split_by_group",
           "ablation", "train_networks"]


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
        check_scalar(self.distance_m, "distance_m", min_val=0.0)
        check_scalar(self.velocity_m_s, "velocity_m_s", min_val=-1e5, max_val=1e5)
        check_scalar(self.acceleration_m_s2, "acceleration_m_s2")
        check_scalar(self.exchanges, "exchanges", min_val=2, integer=True)
        check_scalar(self.true_offset_s, "true_offset_s")
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


def hold_last(est: np.ndarray) -> np.ndarray:
    """Each row with NaN replaced by the last finite value before it (a receiver holds its output)."""
    idx = np.where(np.isfinite(est), np.arange(est.shape[1]), 0)
    np.maximum.accumulate(idx, axis=1, out=idx)
    return np.take_along_axis(est, idx, axis=1)


def run_link(scenario: LinkScenario, algorithms=ALGORITHM_NAMES, *, trials: int = 20, seed=0,
             urt_mode: str = "calibrated", threshold_s: float = 1e-9, networks: dict | None = None,
             outage: tuple[int, int] | None = None) -> dict:
    """Run ``algorithms`` on ``trials`` simulated runs of ``scenario``.

    Returns a dict: ``rmse_s`` and ``convergence_epochs`` per algorithm (K*: first exchange whose
    running RMSE over trials is <= ``threshold_s``, seed eq. 48; None if never), ``pcrb_s`` (the PCRB of the
    offset at the last exchange and its RMS over the run), ``urt_fixed_estimate_s`` (calibrated mode),
    the scenario and the settings. ``networks`` maps "bp" / "lstm" to trained residual networks (the
    algorithms "proposed" and "lstm" need them). ``outage = (k0, k1)`` also runs every algorithm with
    exchanges ``k0 .. k1 - 1`` lost (the stress of seed eqs. 49-50; an algorithm's missing outputs are
    held) and adds ``robustness``: the RMSE increase and the recovery epochs after ``k1``.
    """
    if outage is not None:
        k0, k1 = (int(k) for k in outage)
        if not 1 <= k0 < k1 <= scenario.exchanges:
            raise InputError(f"{{outage}} == {k0}:{k1}, must be K0:K1 with 1 <= K0 < K1 <= {{exchanges}} ({scenario.exchanges})",
                             fields=("outage", "exchanges"))
    check_choice(urt_mode, "urt_mode", ("paper", "calibrated"))
    base = root_seed(seed)
    ex = simulate_scenario(scenario, trials, child_seed(base, 0))
    Z = measurement_array(ex)
    tp = calibrated_urt_s(scenario, child_seed(base, 1)) if urt_mode == "calibrated" else 0.0
    rmse, conv, robust = {}, {}, {}
    for name in algorithms:
        alg = make_algorithm(name, scenario.link, steps=scenario.exchanges, urt_mode=urt_mode, urt_fixed_s=tp,
                             oscillator=preset(scenario.oscillator), networks=networks).fit()
        err = alg.run(Z).offset_s - ex.offset_s
        rmse[name] = rmse_s(err)
        conv[name] = convergence_epochs(err, threshold_s)
        if outage is not None:
            stressed = Z.copy()
            stressed[:, k0:k1, :] = np.nan
            err_stress = hold_last(alg.run(stressed).offset_s) - ex.offset_s
            robust[name] = robustness(hold_last(err + ex.offset_s) - ex.offset_s, err_stress, threshold_s, k1)
    bound = link_pcrb(scenario.link, preset(scenario.oscillator), scenario.exchanges, scenario.distance_m,
                      scenario.velocity_m_s)
    return {
        "rmse_s": rmse,
        "convergence_epochs": conv,
        "pcrb_s": {"final": float(np.sqrt(bound.offset_var_s2[-1])),
                   "rms": float(np.sqrt(np.mean(bound.offset_var_s2)))},
        "urt_fixed_estimate_s": tp,
        "robustness": robust,
        "urt_mode": urt_mode,
        "threshold_s": float(threshold_s),
        "trials": int(trials),
        "scenario": {k: v for k, v in asdict(scenario).items() if k != "link"} | {"link": asdict(scenario.link)},
    }


# --- residual networks: training set, training, ablation (seed 001 sections 2.2.2 and 4.1) ---

TRAIN_WINDOW = 16


def _runs(link: LinkModel, distance_m, velocity_m_s, exchanges: int, seed, oscillator: str = "ocxo") -> Exchanges:
    """Runs with one distance and velocity per trial (arrays of shape (trials,))."""
    base = root_seed(seed)
    osc = preset(oscillator)
    n = len(velocity_m_s)
    xa = node_clock_error_s(osc, exchanges, link.interval_s, child_seed(base, 0), n)
    xb = node_clock_error_s(osc, exchanges, link.interval_s, child_seed(base, 1), n)
    a, b = radial_geometry(np.asarray(distance_m), np.asarray(velocity_m_s))
    return simulate_exchanges(a, b, xa, xb, link, exchanges, child_seed(base, 2))


def residual_dataset(*, samples: int = 100_000, groups: int = 50, runs_per_group: int = 10, exchanges: int = 2000,
                     seed=0, urt_mode: str = "calibrated", window: int = TRAIN_WINDOW) -> dict:
    """The residual networks' data set (seed section 4.1): ``samples`` exchanges from ``groups`` SNRs
    ~ U[4, 20] dB, each with ``runs_per_group`` runs of v ~ U[0, 2000] m/s and distance ~ U[10, 200] km,
    taken after the chain's warm-up (60 %) through the seed chain without its network (URT calibrated:
    the configured fixed part). Targets: ``eps_true - eps_KF``, ns (supervised: uses the truth).

    Returns ``X`` (n, window, 9), ``y_ns`` (n,), ``group`` (n,), ``snr_db`` (n,), ``velocity_m_s`` (n,).
    The 6:2:2 split is by group (:func:`split_by_group`): held-out SNRs and trajectories.
    """
    base = root_seed(seed)
    per_run = int(np.ceil(samples / (groups * runs_per_group)))
    xs, ys, gs, ss, vs = [], [], [], [], []
    for g in range(int(groups)):
        rng = np.random.default_rng(child_seed(base, g, 0))
        snr = float(rng.uniform(4.0, 20.0))
        v = rng.uniform(0.0, 2000.0, runs_per_group)
        d = rng.uniform(10e3, 200e3, runs_per_group)
        link = LinkModel(snr_db=snr)
        ex = _runs(link, d, v, exchanges, child_seed(base, g, 1))
        chain = make_algorithm("proposed-no-nn", link, steps=exchanges, urt_mode=urt_mode,
                               urt_fixed_s=link.urt_fixed_s).fit()
        est, feats = chain.run_features(measurement_array(ex))
        target = (ex.offset_s - est) * 1e9
        first = max(int(0.6 * exchanges), window)
        for r in range(runs_per_group):
            ks = rng.choice(np.arange(first, exchanges), size=per_run, replace=False)
            xs.append(np.stack([feats[r, k - window + 1:k + 1] for k in ks]))
            ys.append(target[r, ks])
            gs.append(np.full(per_run, g))
            ss.append(np.full(per_run, snr))
            vs.append(np.full(per_run, v[r]))
    out = {"X": np.concatenate(xs), "y_ns": np.concatenate(ys), "group": np.concatenate(gs),
           "snr_db": np.concatenate(ss), "velocity_m_s": np.concatenate(vs)}
    return {k: a[:samples] for k, a in out.items()}


def split_by_group(data: dict, seed=0) -> dict:
    """6:2:2 train/validation/test split of :func:`residual_dataset` by group (never one group in two)."""
    groups = np.unique(data["group"])
    order = np.random.default_rng(root_seed(seed)).permutation(groups)
    n_tr, n_va = int(round(0.6 * groups.size)), int(round(0.2 * groups.size))
    parts = {"train": order[:n_tr], "validation": order[n_tr:n_tr + n_va], "test": order[n_tr + n_va:]}
    return {name: {k: a[np.isin(data["group"], g)] for k, a in data.items()} for name, g in parts.items()}


def ablation(network, *, runs: int = 12, exchanges: int = 2000, seed=0, urt_mode: str = "calibrated") -> dict:
    """The chain with and without ``network`` on held-out runs (v ~ U[0, 2000] m/s, SNR ~ U[4, 20] dB,
    distance ~ U[10, 200] km, drawn from a seed the training never used): RMSE (s) of each, per run."""
    base = root_seed(seed)
    rows = []
    for i in range(int(runs)):
        rng = np.random.default_rng(child_seed(base, i, 0))
        snr, v, d = float(rng.uniform(4.0, 20.0)), float(rng.uniform(0.0, 2000.0)), float(rng.uniform(10e3, 200e3))
        link = LinkModel(snr_db=snr)
        ex = _runs(link, [d], [v], exchanges, child_seed(base, i, 1))
        Z = measurement_array(ex)
        plain = make_algorithm("proposed-no-nn", link, steps=exchanges, urt_mode=urt_mode,
                               urt_fixed_s=link.urt_fixed_s).fit()
        with_net = make_algorithm("proposed-no-nn", link, steps=exchanges, urt_mode=urt_mode,
                                  urt_fixed_s=link.urt_fixed_s)
        with_net.residual_model = network
        with_net.fit()
        rows.append({"snr_db": snr, "velocity_m_s": v, "distance_m": d,
                     "rmse_without_s": rmse_s(plain.run(Z).offset_s - ex.offset_s),
                     "rmse_with_s": rmse_s(with_net.run(Z).offset_s - ex.offset_s)})
    return {"runs": rows,
            "rmse_without_s": float(np.sqrt(np.mean([r["rmse_without_s"] ** 2 for r in rows]))),
            "rmse_with_s": float(np.sqrt(np.mean([r["rmse_with_s"] ** 2 for r in rows])))}


def train_networks(out, *, quick: bool = False, seed=0, device: str = "cpu", urt_mode: str = "calibrated",
                   progress=None) -> dict:
    """Build the data set, train the BP 9-32-1 network and the LSTM baseline on it, save both to
    ``out`` (``bp.pt``, ``lstm.pt``) and return a summary: parameter counts, training seconds and
    device, held-out test RMS of the target and of what each network leaves, and the ablation."""
    from pathlib import Path

    from chronofuse.sync.network import ResidualConfig, ResidualNetwork

    out = Path(out)
    size = dict(samples=6000, groups=10, runs_per_group=6, exchanges=1000) if quick else {}
    say = progress or (lambda message: None)
    say("data set")
    data = residual_dataset(seed=child_seed(root_seed(seed), 0), urt_mode=urt_mode, **size)
    split = split_by_group(data, seed=child_seed(root_seed(seed), 1))
    chain = {"filter": "seed", "light_time": "seed", "urt_mode": urt_mode}
    summary = {"samples": {k: int(v["y_ns"].size) for k, v in split.items()}, "networks": {}}
    y_test = split["test"]["y_ns"]
    for kind, window in (("bp", 1), ("lstm", TRAIN_WINDOW)):
        say(f"training {kind}")
        cfg = ResidualConfig(kind=kind, window=window, device=device, chain=chain, epochs=8 if quick else 40)
        part = {k: v["X"][:, -window:, :] for k, v in split.items()}
        net = ResidualNetwork(cfg).fit(part["train"], split["train"]["y_ns"], part["validation"],
                                       split["validation"]["y_ns"])
        path = net.save(out / f"{kind}.pt")
        left = y_test - net.predict_ns(part["test"])
        say(f"ablation {kind}")
        abl = ablation(net, runs=4 if quick else 12, exchanges=size.get("exchanges", 2000),
                       seed=child_seed(root_seed(seed), 2), urt_mode=urt_mode)
        summary["networks"][kind] = {
            "file": str(path), "parameters": net.parameter_count_, "train_seconds": net.train_seconds_,
            "device": net.device_, "epochs": len(net.history_),
            "test_target_rms_ns": float(np.sqrt(np.mean(y_test**2))),
            "test_left_rms_ns": float(np.sqrt(np.mean(left**2))),
            "ablation": abl,
        }
    return summary
