"""The residual networks' data set, training and held-out ablation (orchestration only; the swarm paper's
sections 2.2.2 and 4.1).

The data set is drawn from the link's prior, not from one operating point: each group has its own SNR
~ U[4, 20] dB and each run its own velocity ~ U[0, 2000] m/s, initial range ~ U[10, 200] km, clock offset,
skew and reply delay (:class:`~chronofuse.sync.prior.LinkPrior`) and its own URT calibration; the paper's
chain runs without its network and the target is ``eps_true - eps_KF`` (ns; supervised, uses the truth).
Inputs are offset-invariant (:data:`chronofuse.sync.chain.FEATURES`). The 6:2:2 split is by group.

:func:`ablation` measures what a network is worth on held-out links drawn from the same prior with a seed
the training never used: the chain with and without it on the same exchanges, per link, and the ratio
``RMSE_with / RMSE_without`` with a paired bootstrap interval. A network is kept as an option only where
that interval lies below 1 (docs/sync/notes.md says where it does).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from chronofuse.experiments.swarm import LinkScenario, calibrate_scenario, knowledge_of, simulate_scenario
from chronofuse.models.link import LinkModel
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.metrics import per_trial_mse
from chronofuse.sync.prior import LinkPrior
from chronofuse.sync.registry import make_algorithm

__all__ = ["TRAIN_WINDOW", "residual_dataset", "split_by_group", "ablation", "train_networks", "training_record"]

TRAIN_WINDOW = 16


def _group_runs(snr_db: float, runs: int, exchanges: int, seed, urt_mode: str, prior: LinkPrior):
    """One group's runs: per-run velocity and range drawn here, the rest from the prior; returns the
    scenario, the exchanges, their measurements and the chain (without network) fitted to them."""
    rng = np.random.default_rng(child_seed(root_seed(seed), 0))
    v = rng.uniform(0.0, 2000.0, runs)
    d = rng.uniform(10e3, 200e3, runs)
    sc = LinkScenario(link=LinkModel(snr_db=snr_db), exchanges=exchanges, prior=prior.model_copy(update={"range_spread_m": 0.0}))
    out = []
    for r in range(runs):
        one = replace(sc, velocity_m_s=float(v[r]), distance_m=float(d[r]))
        ex, draw = simulate_scenario(one, 1, child_seed(root_seed(seed), 1, r))
        calib = calibrate_scenario(one, draw, child_seed(root_seed(seed), 2, r))
        chain = make_algorithm("rtt-rvc-kf", knowledge_of(one, calib, urt_mode)).fit()
        out.append((one, ex, measurement_array(ex), chain, calib))
    return out


def residual_dataset(*, samples: int = 100_000, groups: int = 50, runs_per_group: int = 10, exchanges: int = 2000,
                     seed=0, urt_mode: str = "calibrated", window: int = TRAIN_WINDOW,
                     prior: LinkPrior = LinkPrior()) -> dict:
    """The residual networks' data set (module docstring), taken after the chain's warm-up (60 %).

    Returns ``X`` (n, window, 9), ``y_ns`` (n,), ``group`` (n,), ``snr_db`` (n,), ``velocity_m_s`` (n,).
    """
    base = root_seed(seed)
    per_run = int(np.ceil(samples / (groups * runs_per_group)))
    xs, ys, gs, ss, vs = [], [], [], [], []
    for g in range(int(groups)):
        rng = np.random.default_rng(child_seed(base, g, 0))
        snr = float(rng.uniform(4.0, 20.0))
        for sc, ex, Z, chain, _ in _group_runs(snr, runs_per_group, exchanges, child_seed(base, g, 1), urt_mode, prior):
            est, feats = chain.run_features(Z)
            target = (ex.offset_s - est)[0] * 1e9
            first = max(int(0.6 * exchanges), window)
            ks = rng.choice(np.arange(first, exchanges), size=per_run, replace=False)
            xs.append(np.stack([feats[0, k - window + 1:k + 1] for k in ks]))
            ys.append(target[ks])
            gs.append(np.full(per_run, g))
            ss.append(np.full(per_run, snr))
            vs.append(np.full(per_run, sc.velocity_m_s))
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


def ablation(network, *, runs: int = 40, exchanges: int = 2000, seed=0, urt_mode: str = "calibrated",
             prior: LinkPrior = LinkPrior(), offset_shift_s: float = 0.0) -> dict:
    """The chain with and without ``network`` on held-out links (module docstring). ``offset_shift_s`` moves
    every link's offset prior (a hold-out condition the training never saw).

    Returns per-run RMSEs, their RMS, and ``ratio`` = RMSE with / without with its 95 % paired interval.
    """
    from chronofuse.sync.metrics import ratio_interval

    base = root_seed(seed)
    shifted = prior.model_copy(update={"offset_mean_s": prior.offset_mean_s + offset_shift_s})
    rows, mse_with, mse_without = [], [], []
    for i in range(int(runs)):
        rng = np.random.default_rng(child_seed(base, i, 0))
        snr = float(rng.uniform(4.0, 20.0))
        (sc, ex, Z, plain, calib), = _group_runs(snr, 1, exchanges, child_seed(base, i, 1), urt_mode, shifted)
        with_net = make_algorithm("rtt-rvc-kf", knowledge_of(sc, calib, urt_mode))
        with_net.residual_model = network
        with_net.fit()
        a = per_trial_mse(plain.run(Z).offset_s - ex.offset_s)[0]
        b = per_trial_mse(with_net.run(Z).offset_s - ex.offset_s)[0]
        mse_without.append(a)
        mse_with.append(b)
        rows.append({"snr_db": snr, "velocity_m_s": sc.velocity_m_s, "distance_m": sc.distance_m,
                     "rmse_without_s": float(np.sqrt(a)), "rmse_with_s": float(np.sqrt(b))})
    ratio, lo, hi = ratio_interval(np.array(mse_with), np.array(mse_without))
    return {"runs": rows, "rmse_without_s": float(np.sqrt(np.mean(mse_without))),
            "rmse_with_s": float(np.sqrt(np.mean(mse_with))), "ratio": ratio, "ratio_ci": [lo, hi],
            "offset_shift_s": offset_shift_s, "earns_its_place": bool(hi < 1.0)}


def training_record(*, seed=0, quick: bool = False, urt_mode: str = "calibrated", command: str | None = None) -> dict:
    """What a model file keeps of its training: its settings and, where the caller gives it, the command line
    that wrote it (the library knows no command line: the command passes its own)."""
    return {"command": command, "seed": seed, "quick": quick, "urt_mode": urt_mode}


def train_networks(out, *, quick: bool = False, seed=0, device: str = "cpu", urt_mode: str = "calibrated",
                   progress=None, command: str | None = None) -> dict:
    """Build the data set, train the BP 9-32-1 network and the LSTM baseline on it, save both to ``out``
    (``bp.pt``, ``lstm.pt``) and return a summary: parameter counts, training seconds and device, held-out
    test RMS of the target and of what each network leaves, and the ablation at the prior and with the
    offsets shifted by 1 us."""
    from chronofuse.sync.residual import ResidualConfig, ResidualNetwork, _device

    _device(ResidualConfig(device=device))  # an absent GPU is refused now, not after the data set is built
    out = Path(out)
    size = dict(samples=6000, groups=10, runs_per_group=6, exchanges=1000) if quick else {}
    say = progress or (lambda message: None)
    say("data set")
    data = residual_dataset(seed=child_seed(root_seed(seed), 0), urt_mode=urt_mode, **size)
    split = split_by_group(data, seed=child_seed(root_seed(seed), 1))
    chain = {"light_time": "paper", "urt_mode": urt_mode}
    summary = {"samples": {k: int(v["y_ns"].size) for k, v in split.items()}, "networks": {}}
    y_test = split["test"]["y_ns"]
    for kind, window in (("bp", 1), ("lstm", TRAIN_WINDOW)):
        say(f"training {kind}")
        cfg = ResidualConfig(kind=kind, window=window, device=device, chain=chain, epochs=8 if quick else 40)
        part = {k: v["X"][:, -window:, :] for k, v in split.items()}
        net = ResidualNetwork(cfg).fit(part["train"], split["train"]["y_ns"], part["validation"],
                                       split["validation"]["y_ns"])
        path = net.save(out / f"{kind}.pt", training=training_record(seed=seed, quick=quick, urt_mode=urt_mode,
                                                                          command=command))
        left = y_test - net.predict_ns(part["test"])
        say(f"ablation {kind}")
        runs = 10 if quick else 40  # 10: the fewest held-out links given an interval (MIN_INTERVAL_TRIALS)
        exchanges = size.get("exchanges", 2000)
        abl = ablation(net, runs=runs, exchanges=exchanges, seed=child_seed(root_seed(seed), 2), urt_mode=urt_mode)
        shifted = ablation(net, runs=runs, exchanges=exchanges, seed=child_seed(root_seed(seed), 3), urt_mode=urt_mode,
                           offset_shift_s=1e-6)
        summary["networks"][kind] = {
            "file": path.name, "sha256": net.digest_, "parameters": net.parameter_count_, "train_seconds": net.train_seconds_,
            "device": net.device_, "epochs": len(net.history_),
            "test_target_rms_ns": float(np.sqrt(np.mean(y_test**2))),
            "test_left_rms_ns": float(np.sqrt(np.mean(left**2))),
            "ablation": abl, "ablation_offset_1us": shifted,
        }
    return summary
