"""Holdover after a locked stretch: ours beside the causal optimal predictor and the analytic floor.

Every trial: the oscillator runs free-running truth for ``locked_s + max(horizons)`` seconds; the
receivers give the fused reference (the equal-weight mean of equal receivers) for the first
``locked_s`` seconds, none after. Two loops close on the same data:

* ours, the default controller as ``chronofuse gnssdo`` designs it: fitted once on a calibration record
  (:func:`chronofuse.experiments.gnssdo_design.fitted_controller`; ``design="datasheet"``: from the
  presets' figures, :func:`~chronofuse.experiments.gnssdo.make_controller`);
* the causal optimal predictor: the clairvoyant servo (:func:`chronofuse.discipline.bound.clairvoyant_servo`,
  the true model with flicker FM as its Gauss-Markov bank, and the oscillator's aging as a known constant,
  as the simulation draws it) on the same locked data; in holdover its
  update is skipped and its unconstrained steering follows its own prediction, so its time error after
  ``h`` is its prediction error. Its Riccati covariance at ``t0 + h`` is printed beside it
  (``clairvoyant_predicted_ns``).

The analytic floor is what the oscillator does after ``t0`` that no past can predict: the random-walk
FM and white FM increments after entry, ``sqrt(q h^3 / 3 + h0 h / 2)`` with ``q = 2 pi^2 h-2`` (the
integrated Wiener process, e.g. the clock model's ``Q``; flicker FM is partly predictable from the past
and adds to what is left). Every figure is an rms over trials with its 95 % interval
(:mod:`chronofuse.analysis.montecarlo`); ``ratio`` is ours over the clairvoyant's, paired.
Trials run in chunks so that memory stays bounded.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from chronofuse.analysis.montecarlo import ratio_ci, rms_ci
from chronofuse.discipline.bound import clairvoyant_servo, time_error_bound
from chronofuse.discipline.dac import Dac
from chronofuse.discipline.holdover import holdover_error
from chronofuse.discipline.loop import close_loop
from chronofuse.experiments.gnssdo import DEFAULT_CONTROLLER, _free_phase, make_controller, scenario_environment
from chronofuse.models.oscillator_presets import preset
from chronofuse.models.receiver import simulate_receivers
from chronofuse.seeding import child_seed, root_seed
from chronofuse.validation import check_scalar

__all__ = ["holdover_floor_s", "holdover_study"]

Progress = Callable[[str], None]


def holdover_floor_s(h0: float, hm2: float, horizon_s) -> np.ndarray:
    """``sqrt(2 pi^2 hm2 h^3 / 3 + h0 h / 2)`` (s): the part of the holdover error no predictor removes."""
    h = np.asarray(horizon_s, dtype=float)
    return np.sqrt(2.0 * math.pi**2 * hm2 * h**3 / 3.0 + h0 * h / 2.0)


def _ci(t) -> list | None:
    return None if not math.isfinite(t[1]) else [t[1], t[2]]


def holdover_study(locked_s: int = 86_400, horizons_s=(3600.0, 4 * 3600.0, 86_400.0), trials: int = 200, *,
                   oscillator: str = "ocxo", receivers: int = 2, controller: str = DEFAULT_CONTROLLER,
                   seed: int = 3, chunk: int = 25, design: str = "fit", progress: Progress = lambda s: None,
                   temperature_amplitude_K: float = 0.0, compensation_error: float | None = None) -> dict:
    """Run the study (module docstring); returns horizons, each figure in ns with its interval, the ratio.

    ``temperature_amplitude_K``: a diurnal swing (:func:`chronofuse.models.temperature.diurnal_profile`, rising
    through its mean at the holdover's start) acts through the preset's tempco on both loops' oscillator;
    ``compensation_error``: a compensation table of the tempco times ``1 + compensation_error`` is applied
    (feed-forward). Each row then carries ``temperature_theory_ns``, the tempco integral over the horizon
    (:func:`chronofuse.models.temperature.holdover_temperature_error_s`, less the table's share)."""
    check_scalar(locked_s, "locked_s", min_val=3600, integer=True)
    check_scalar(trials, "trials", min_val=2, integer=True)
    check_scalar(chunk, "chunk", min_val=1, integer=True)
    horizons = np.asarray(horizons_s, dtype=float)
    osc = preset(oscillator)
    dac = Dac.for_oscillator(osc)
    env = scenario_environment("open-sky", float(locked_s))
    steps = int(locked_s + horizons.max() + 1)
    if design == "fit":
        from chronofuse.experiments.gnssdo_design import fitted_controller

        servo, how = fitted_controller(controller, osc, env, receivers, dac, root_seed(seed))
    else:
        servo, how = make_controller(controller, osc, env, receivers, dac), "datasheet"
    from chronofuse.models.temperature import (CompensationTable, compensated_phase_s, diurnal_profile,
                                               holdover_temperature_error_s)

    temp_phase, temp_theory, table = 0.0, None, None
    if temperature_amplitude_K:
        temp = diurnal_profile(steps, mean_K=osc.temp_ref_K, amplitude_K=temperature_amplitude_K,
                               phase_rad=-2.0 * math.pi * locked_s / 86_400.0)
        if compensation_error is not None:
            table = CompensationTable.from_tempco(osc.temp_coeff_per_K * (1.0 + compensation_error), osc.temp_ref_K,
                                                  osc.temp_ref_K - 2 * temperature_amplitude_K,
                                                  osc.temp_ref_K + 2 * temperature_amplitude_K)
        temp_phase = compensated_phase_s(temp, osc.temp_coeff_per_K, osc.temp_ref_K, table)
        temp_theory = holdover_temperature_error_s(temp, int(locked_s), horizons, osc.temp_coeff_per_K, table)
    ours_err, best_err = [], []
    for start in range(0, trials, chunk):
        n = min(chunk, trials - start)
        progress(f"holdover trials {start}..{start + n - 1} of {trials}")
        root = root_seed(seed + 1000 * (start // chunk))
        free, _ = _free_phase(osc, steps, n, root)
        free = free + temp_phase
        rx = simulate_receivers(env, int(locked_s), receivers, child_seed(root, 1), trials=n)
        ref = np.full((n, steps), np.nan)
        ref[:, :locked_s] = np.nanmean(rx.pps_error_s + rx.epochs.qerr_s, axis=1)
        del rx
        ours = close_loop(servo, free, ref)
        ours_err.append(holdover_error(ours.phase_s, locked_s, horizons))
        del ours
        best = close_loop(clairvoyant_servo(osc, env, receivers, dac), free, ref)
        best_err.append(holdover_error(best.phase_s, locked_s, horizons))
        del best, free, ref
    ours_err = np.concatenate(ours_err)
    best_err = np.concatenate(best_err)
    mask = np.zeros(steps, bool)
    mask[:locked_s] = True
    predicted = np.sqrt(time_error_bound(clairvoyant_servo(osc, env, receivers, dac), mask).variance_s2[0])
    floor = holdover_floor_s(osc.h.h0, osc.h.hm2, horizons)
    rows = []
    for j, h in enumerate(horizons):
        o = rms_ci(ours_err[:, j] ** 2)
        b = rms_ci(best_err[:, j] ** 2)
        r = ratio_ci(ours_err[:, j] ** 2, best_err[:, j] ** 2)
        rows.append({"horizon_s": float(h), "ours_ns": o[0] * 1e9, "ours_ci_ns": _ci(tuple(v * 1e9 for v in o)),
                     "clairvoyant_ns": b[0] * 1e9, "clairvoyant_ci_ns": _ci(tuple(v * 1e9 for v in b)),
                     "clairvoyant_predicted_ns": float(predicted[locked_s + int(h)]) * 1e9,
                     "floor_ns": float(floor[j]) * 1e9, "ratio": r[0], "ratio_ci": _ci(r),
                     **({} if temp_theory is None else {"temperature_theory_ns": float(temp_theory[j]) * 1e9})})
    return {"oscillator": oscillator, "receivers": receivers, "controller": controller, "design": how,
            "locked_s": int(locked_s),
            "trials": int(trials), "seed": seed, "temperature_amplitude_K": temperature_amplitude_K,
            "compensation_error": compensation_error, "rows": rows}


def write_study(study: dict, out_dir) -> list[str]:
    """``holdover.json`` and ``holdover.md`` (a table written from ``study``) into ``out_dir``."""
    from pathlib import Path

    from chronofuse.report.jsonio import dumps

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "holdover.json").write_text(dumps(study) + "\n")

    def ci(v):
        return "-" if v is None else f"{v[0]:.4g}..{v[1]:.4g}"

    lines = [f"# Holdover after {study['locked_s'] / 3600:g} h locked ({study['oscillator']}, {study['receivers']} "
             f"receivers, {study['controller']} designed by {study['design']}, {study['trials']} trials, "
             f"seed {study['seed']})", "",
             "rms over trials, 95 % Monte Carlo intervals; written by "
             "`python -m chronofuse.experiments.gnssdo_holdover`.", "",
             "| horizon | ours (ns) | 95 % CI | causal optimal predictor (ns) | 95 % CI | its covariance (ns) | "
             "analytic floor (ns) | ours / optimal | 95 % CI |", "|---|---|---|---|---|---|---|---|---|"]
    for r in study["rows"]:
        lines.append(f"| {r['horizon_s'] / 3600:g} h | {r['ours_ns']:.4g} | {ci(r['ours_ci_ns'])} | "
                     f"{r['clairvoyant_ns']:.4g} | {ci(r['clairvoyant_ci_ns'])} | {r['clairvoyant_predicted_ns']:.4g} | "
                     f"{r['floor_ns']:.4g} | {r['ratio']:.3f} | {ci(r['ratio_ci'])} |")
    (out / "holdover.md").write_text("\n".join(lines) + "\n")
    return ["holdover.json", "holdover.md"]


if __name__ == "__main__":
    # The published study (docs/gnssdo/holdover.md): 200 trials after a day locked, seed 3. Other settings are
    # the arguments of holdover_study; `chronofuse reproduce gnssdo` runs it with the command line's.
    print(write_study(holdover_study(86_400, trials=200, seed=3, progress=print), "docs/gnssdo"))
