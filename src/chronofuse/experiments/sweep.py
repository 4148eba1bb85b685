"""Parameter sweeps of the two-node link on Dask (orchestration only).

A sweep is a list of tasks, one per (parameter value, chunk of ``chunk_trials`` trials). Task
``(value, c)`` simulates its trials from ``child_seed(root, key(value), c)``, ``key`` the value's
float64 bit pattern as an integer, calibrates each trial's link on its own (so the calibration-to-
calibration spread is in the trials) and runs every algorithm on them, so its numbers depend only on its
own spec: not on the other values swept, nor on the process, worker or machine that runs it; a Dask run
equals a serial one bit for bit. Each row also carries the trial's Bayesian bound, and the summary gives
every RMSE and its ratio to the bound with percentile-bootstrap intervals over trials.

Where tasks run: ``scheduler=None`` starts a LocalCluster of worker processes (one thread each);
``"serial"`` runs them in this process (small runs, tests); ``"tcp://HOST:PORT"`` sends them to an
existing Dask scheduler. Results are a tidy table: one row per (value, algorithm, trial).
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pandas as pd

from chronofuse.experiments.swarm import (LinkScenario, bound_of, calibrate_scenario, knowledge_of, score_trials,
                                         simulate_scenario)
from chronofuse.seeding import child_seed, root_seed
from chronofuse.sync.base import measurement_array
from chronofuse.sync.metrics import per_trial_bound_var, per_trial_mse
from chronofuse.sync.registry import make_algorithm
from chronofuse.validation import InputError, check_choice, check_scalar

__all__ = ["SWEEP_PARAMS", "scenario_at", "sweep_tasks", "run_task", "run_sweep", "summarize"]

#: Sweepable parameters and the unit of their values.
SWEEP_PARAMS = {"velocity": "m/s", "distance": "m", "reply-delay": "s", "urt": "s", "snr": "dB"}
#: The table's columns (one row per value, algorithm and trial).
COLUMNS = ["param", "value", "algorithm", "trial", "rmse_ns", "bound_rms_ns"]


def value_key(value: float) -> int:
    """A swept value's seed key: its float64 bit pattern as a non-negative integer."""
    return int.from_bytes(np.float64(value).tobytes(), "little")


def scenario_at(base: LinkScenario, param: str, value: float) -> LinkScenario:
    """``base`` with ``param`` (one of :data:`SWEEP_PARAMS`) set to ``value``."""
    check_choice(param, "param", tuple(SWEEP_PARAMS))
    if param == "velocity":
        return replace(base, velocity_m_s=float(value))
    if param == "distance":
        return replace(base, distance_m=float(value))
    link = base.link
    if param == "reply-delay":
        link = replace(link, reply_delay_s=float(value))
    elif param == "urt":
        link = replace(link, urt_fixed_s=float(value))
    else:
        link = replace(link, snr_db=float(value))
    return replace(base, link=link)


def sweep_tasks(base: LinkScenario, param: str, values, algorithms, *, trials: int, seed, chunk_trials: int = 25,
                urt_mode: str = "calibrated", model_files: dict | None = None) -> list[dict]:
    """The task specs of a sweep (plain picklable dicts); ``model_files`` maps "bp" / "lstm" to saved
    residual networks, loaded by each task (checked against their configuration)."""
    check_scalar(trials, "trials", min_val=1, integer=True)
    check_scalar(chunk_trials, "chunk_trials", min_val=1, integer=True)
    check_choice(urt_mode, "urt_mode", ("paper", "calibrated"))
    values = [float(v) for v in values]
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:  # a repeated value draws the same seeds: the same trials twice, counted as twice the trials
        raise InputError(f"{{values}} == {','.join(f'{v:g}' for v in values)} repeats "
                         f"{', '.join(f'{v:g}' for v in repeated)}: give each value once", fields=("values",))
    root = root_seed(seed)
    tasks = []
    for value in values:
        scenario = scenario_at(base, param, value)
        key = value_key(value)
        for c, start in enumerate(range(0, int(trials), int(chunk_trials))):
            n = min(int(chunk_trials), int(trials) - start)
            tasks.append({"param": param, "value": float(value), "scenario": scenario, "algorithms": tuple(algorithms),
                          "seed": child_seed(root, key, c), "first_trial": start, "trials": n, "urt_mode": urt_mode,
                          "model_files": dict(model_files or {})})
    return tasks


def run_task(task: dict) -> pd.DataFrame:
    """One task: its trials (each calibrated on its own), every algorithm; rows of :data:`COLUMNS`."""
    sc: LinkScenario = task["scenario"]
    base = root_seed(task["seed"])
    ex, draw = simulate_scenario(sc, task["trials"], child_seed(base, 0))
    calib = calibrate_scenario(sc, draw, child_seed(base, 1))
    know = knowledge_of(sc, calib, task["urt_mode"])
    Z = measurement_array(ex)
    networks = _load_networks(task.get("model_files", {}), task["urt_mode"])
    bound_var = bound_of(sc, ex, calib).offset_var_s2
    rows = []
    for name in task["algorithms"]:
        alg = make_algorithm(name, know, networks=networks).fit()
        err = alg.run(Z).offset_s - ex.offset_s
        per_trial = np.sqrt(per_trial_mse(err)) * 1e9
        bound_ns = np.sqrt(per_trial_bound_var(bound_var, err)) * 1e9  # over the exchanges it is scored on
        for j, value in enumerate(per_trial):
            rows.append((task["param"], task["value"], name, task["first_trial"] + j, float(value), float(bound_ns[j])))
    return pd.DataFrame(rows, columns=COLUMNS)


def _load_networks(files: dict, urt_mode: str) -> dict:
    """The residual networks named in a task (paths -> loaded, each checked against its configuration)."""
    from chronofuse.sync.residual import load_residual_network

    chain = {"light_time": "paper", "urt_mode": urt_mode}
    return {kind: load_residual_network(path, chain=chain) for kind, path in files.items()}


def _client(scheduler: str | None, n_tasks: int):
    """(client, cluster) for ``scheduler``; raises InputError naming an unreachable address."""
    from chronofuse.extras import require

    distributed = require("distributed", "a parameter sweep on Dask")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster

    if scheduler is None or scheduler == "local":
        workers = max(1, min(os.cpu_count() or 1, n_tasks))
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               host="127.0.0.1")
        return Client(cluster), cluster
    if not scheduler.startswith("tcp://"):
        raise InputError(f"{{scheduler}} == {scheduler!r}, must be 'local', 'serial' or tcp://HOST:PORT",
                         fields=("scheduler",))
    try:
        return Client(scheduler, timeout="5s"), None
    except (OSError, TimeoutError) as exc:
        raise InputError(f"{{scheduler}} == {scheduler!r}: no Dask scheduler answers there ({type(exc).__name__})",
                         fields=("scheduler",)) from None


def run_sweep(base: LinkScenario, param: str, values, algorithms, *, trials: int = 100, seed=0, chunk_trials: int = 25,
              urt_mode: str = "calibrated", scheduler: str | None = None, progress=None,
              model_files: dict | None = None) -> pd.DataFrame:
    """Run a sweep (module docstring); ``progress(done_trials, total_trials)`` is called as tasks finish.

    Returns the tidy table sorted by (value, algorithm, trial).
    """
    tasks = sweep_tasks(base, param, values, algorithms, trials=trials, seed=seed, chunk_trials=chunk_trials,
                        urt_mode=urt_mode, model_files=model_files)
    total = sum(t["trials"] for t in tasks)
    frames, done = [], 0
    if scheduler == "serial":
        for task in tasks:
            frames.append(run_task(task))
            done += task["trials"]
            if progress:
                progress(done, total)
    else:
        from distributed import as_completed

        client, cluster = _client(scheduler, len(tasks))
        try:
            futures = client.map(run_task, tasks, pure=False)
            by_key = {f.key: t for f, t in zip(futures, tasks)}
            for fut in as_completed(futures):
                frames.append(fut.result())
                done += by_key[fut.key]["trials"]
                if progress:
                    progress(done, total)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    table = pd.concat(frames, ignore_index=True)
    return table.sort_values(["value", "algorithm", "trial"], kind="mergesort").reset_index(drop=True)


def summarize(table: pd.DataFrame, confidence: float = 0.95) -> pd.DataFrame:
    """Per (value, algorithm): the trial count, RMSE over trials ``sqrt(mean(rmse_trial^2))`` (equal run
    lengths) with its bootstrap interval ``rmse_lo_ns``/``rmse_hi_ns``, the bound's RMS over the same trials
    (each trial's over the exchanges the algorithm is scored on, :func:`~chronofuse.sync.metrics.per_trial_bound_var`)
    and the ratio of the two with its paired interval (:mod:`chronofuse.sync.metrics`). A trial where the
    algorithm had no estimate (``rmse_ns`` NaN) is left out of both, counted in ``unscored`` and warned of
    (:func:`chronofuse.experiments.swarm.score_trials`); the intervals are NaN below
    :data:`~chronofuse.sync.metrics.MIN_INTERVAL_TRIALS` scored trials."""
    check_scalar(confidence, "confidence", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
    rows = []
    for (value, name), g in table.groupby(["value", "algorithm"], sort=True):
        mse, bnd = np.square(g["rmse_ns"].to_numpy()), np.square(g["bound_rms_ns"].to_numpy())
        r, lo, hi, q, qlo, qhi, unscored = score_trials(f"{name} at {value:g}", mse, bnd, confidence)
        rows.append({"value": value, "algorithm": name, "trials": int(len(g)), "unscored": len(unscored),
                     "rmse_ns": r, "rmse_lo_ns": lo, "rmse_hi_ns": hi,
                     "bound_rms_ns": float(np.sqrt(np.nanmean(bnd))) if np.isfinite(bnd).any() else float("nan"),
                     "ratio": q, "ratio_lo": qlo, "ratio_hi": qhi})
    return pd.DataFrame(rows)
