"""Validation figures for docs/: the stability engine and the truth models against outside references.

``run_validation(data_dir, out_dir)`` computes the numbers below from the records shipped with the package
(:func:`shipped_data`, or ``data_dir``) and, only when ``out_dir`` is given, writes the PNGs and
``validation.json`` (the numbers plotted) there; :mod:`chronofuse.experiments.validation_checks` turns the
numbers into PASS/FAIL verdicts:

1. ``gps_deviations.png``, ``gps_tdev.png``: ADEV (decade grid), MDEV, MTOTDEV and TDEV (octave grid)
   of the real GPS 1PPS-vs-H-maser record (``stability/gps``) with Stable32's tables overlaid
   (Stable32 has no MTOTDEV table for this record: MTOTDEV is plotted alone).
2. ``receiver_calibration.png``: ADEV of the simulated open-sky receiver's qErr-corrected 1PPS
   (``pps_error_s + qerr_s``), of its raw ``pps_error_s`` (48 MHz sawtooth left in) and the analytic
   :func:`~chronofuse.analysis.theory.corrected_pps_adev`, against Stable32's ADEV table of that record;
   the record's statistics behind the calibration are re-measured (:func:`record_statistics`).
3. ``oscillator_<preset>.png``: simulated OADEV (independent trials pooled) with its confidence
   interval against :func:`~chronofuse.analysis.theory.adev_theory` (noise and drift), per preset.
4. ``cs5071a_mtie.png``, ``cs5071a_tdev.png``: MTIE and TDEV of the Cs 5071A record against the
   PRTC-A, PRTC-B and G.811 masks, with Stable32's MTIE and TDEV tables overlaid.

This module computes; :mod:`chronofuse.report.validation_figures` draws. Run as ``chronofuse validate``
(the table of verdicts; ``--out docs/figures`` also writes the figures; ``--quick``: shorter simulations
and a shorter MTOTDEV range; ``--data DIR``: records from another folder holding the same layout).
"""

from __future__ import annotations

import time
from importlib import resources
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.signal
import scipy.stats

import chronofuse.analysis.stability as st
from chronofuse.experiments import VALIDATION_SEED
from chronofuse.analysis.masks import MASKS
from chronofuse.analysis.metrics import pooled_oadev
from chronofuse.analysis.theory import adev_theory
from chronofuse.io.records import read_record
from chronofuse.io.stable32 import read_stable32_table
from chronofuse.models.oscillator import simulate_oscillator
from chronofuse.models.oscillator_presets import PRESETS
from chronofuse.analysis.theory import corrected_pps_adev
from chronofuse.models.environment import receiver_environment
from chronofuse.models.receiver import simulate_receivers
from chronofuse.report import validation_figures as figures
from chronofuse.report.jsonio import dumps
from chronofuse.validation import InputError, check_scalar

__all__ = [
    "ValidationSettings",
    "FULL",
    "QUICK",
    "write_validation_figures",
    "run_validation",
    "shipped_data",
    "record_statistics",
]

#: Root seed of every simulation here (one SeedSequence per experiment).
SEED = VALIDATION_SEED


@dataclass(frozen=True)
class ValidationSettings:
    """Sizes of the validation runs.

    Attributes
    ----------
    receiver_duration_s : int
        Length of the simulated open-sky receiver run, s (1 Hz).
    oscillator_duration_s : float
        Length of each simulated oscillator run, s (1 Hz).
    oscillator_trials : int
        Independent realisations of each oscillator preset, pooled (mean Allan variance).
    mtotdev_max_tau_s : float
        Largest MTOTDEV averaging time on the GPS record, s (its cost grows as N m per factor).
    """

    receiver_duration_s: int
    oscillator_duration_s: float
    oscillator_trials: int
    mtotdev_max_tau_s: float

    def __post_init__(self):
        check_scalar(self.receiver_duration_s, "receiver_duration_s", min_val=1000, integer=True)
        check_scalar(self.oscillator_duration_s, "oscillator_duration_s", min_val=1000.0)
        check_scalar(self.oscillator_trials, "oscillator_trials", min_val=1, integer=True)
        check_scalar(self.mtotdev_max_tau_s, "mtotdev_max_tau_s", min_val=1.0)


#: The run behind docs/figures: the receiver as long as the GPS record, 8 x 2e5 s per oscillator preset.
FULL = ValidationSettings(
    receiver_duration_s=241_218, oscillator_duration_s=200_000.0, oscillator_trials=8, mtotdev_max_tau_s=65536.0
)
#: A smoke run for tests.
QUICK = ValidationSettings(
    receiver_duration_s=20_000, oscillator_duration_s=20_000.0, oscillator_trials=2, mtotdev_max_tau_s=256.0
)


def _max_rel_diff(ours: np.ndarray, table: np.ndarray) -> float:
    return float(np.max(np.abs(ours / table - 1.0)))


def _gps_figures(out_dir: Path | None, stab: Path, x: np.ndarray, settings: ValidationSettings) -> tuple[list[Path], dict]:
    tables = {
        "adev": read_stable32_table(stab / "gps" / "stable32_ADEV_decade.txt"),
        "mdev": read_stable32_table(stab / "gps" / "stable32_MDEV_octave.txt"),
        "tdev": read_stable32_table(stab / "gps" / "stable32_TDEV_octave.txt"),
    }
    ours = {name: st.compute(name, x, 1.0, tables[name]["tau"]) for name in tables}
    octave_tau_s = st.averaging_factors(st.STATISTICS["mtotdev"].max_m(x.size), "octave").astype(float)
    mtot_tau = octave_tau_s[octave_tau_s <= settings.mtotdev_max_tau_s]
    ours["mtotdev"] = st.mtotdev(x, 1.0, mtot_tau)
    paths = [] if out_dir is None else figures.gps_figures(out_dir, ours, tables, x.size)
    numbers = {
        "n_points": int(x.size),
        "ours": {name: dev.to_dict() for name, dev in ours.items()},
        "stable32": {
            name: {key: t[key] for key in ("tau", "dev", "n", "lo", "hi")} for name, t in tables.items()
        },
        "max_rel_diff_to_stable32": {name: _max_rel_diff(ours[name].dev, tables[name]["dev"]) for name in tables},
        "n_equal_to_stable32": {name: bool(np.array_equal(ours[name].n, tables[name]["n"])) for name in tables},
    }
    return paths, numbers


def record_statistics(x_s: np.ndarray, oadev_table: dict[str, np.ndarray], max_tau_s: float = 8192.0) -> dict:
    """The statistics behind the open-sky calibration (``chronofuse.models.receiver_model`` docstring), re-measured.

    ``x_s`` (N,) the 1 Hz GPS-vs-maser phase in seconds; ``oadev_table`` Stable32's OADEV octave table
    (:func:`read_stable32_table`). Returns the Pearson kurtosis of the second difference, the largest
    first difference in units of its standard deviation, the lag-1 correlation of the first difference,
    the median one-sided phase PSD above 0.1 Hz (Welch, 4096-point segments, s^2/Hz) and the white
    sigma it implies (``sqrt(level f_h)``, f_h = 0.5 Hz), and the worst misfit ``|ln(model/table)|`` of
    :func:`~chronofuse.analysis.theory.corrected_pps_adev` of the open-sky preset up to ``max_tau_s``.
    """
    d1 = np.diff(x_s)
    d2 = np.diff(x_s, 2)
    centred = d1 - d1.mean()
    freq, psd = scipy.signal.welch(x_s - x_s.mean(), fs=1.0, nperseg=4096)
    level = float(np.median(psd[freq > 0.1]))
    keep = oadev_table["tau"] <= max_tau_s
    open_sky = receiver_environment("open-sky").model
    ratio = corrected_pps_adev(open_sky, oadev_table["tau"][keep]) / oadev_table["dev"][keep]
    return {
        "kurtosis_second_difference": float(scipy.stats.kurtosis(d2, fisher=False)),
        "max_first_difference_s": float(np.abs(centred).max()),
        "max_first_difference_sigmas": float(np.abs(centred).max() / centred.std()),
        "lag1_correlation_first_difference": float(np.corrcoef(d1[:-1], d1[1:])[0, 1]),
        "phase_psd_above_0p1_hz_s2_per_hz": level,
        "white_sigma_from_psd_s": float(np.sqrt(level * 0.5)),
        "analytic_to_oadev_table_tau": oadev_table["tau"][keep],
        "analytic_to_oadev_table_ratio": ratio,
        "analytic_worst_misfit": float(np.abs(np.log(ratio)).max()),
    }


def _receiver_figure(
    out_dir: Path | None, stab: Path, x: np.ndarray, settings: ValidationSettings, seed: int
) -> tuple[list[Path], dict]:
    table = read_stable32_table(stab / "gps" / "stable32_ADEV_decade.txt")
    truth = simulate_receivers("open-sky", settings.receiver_duration_s, 1, np.random.SeedSequence([seed, 2]))
    corrected = truth.pps_error_s[0, 0] + truth.epochs.qerr_s[0, 0]
    raw = np.array(truth.pps_error_s[0, 0])
    tau = table["tau"][table["tau"] <= st.STATISTICS["adev"].max_m(corrected.size)]
    with np.errstate(all="ignore"):
        sim = st.adev(corrected, 1.0, tau)
        sim_raw = st.adev(raw, 1.0, tau)
    analytic = corrected_pps_adev(receiver_environment("open-sky").model, table["tau"])
    paths = [] if out_dir is None else [
        figures.receiver_figure(out_dir, sim, sim_raw, table, analytic, settings.receiver_duration_s)]
    keep = np.isin(table["tau"], sim.tau_s)
    numbers = {
        "duration_s": settings.receiver_duration_s,
        "seed": [seed, 2],
        "tau": sim.tau_s,
        "sim_corrected_adev": sim.dev,
        "sim_raw_adev": sim_raw.dev,
        "analytic_adev": analytic[keep],
        "stable32_adev": table["dev"][keep],
        "ratio_sim_to_stable32": sim.dev / table["dev"][keep],
        "ratio_raw_to_corrected": sim_raw.dev / sim.dev,
        "ratio_analytic_to_stable32": analytic[keep] / table["dev"][keep],
        "record": record_statistics(x, read_stable32_table(stab / "gps" / "stable32_OADEV_octave.txt")),
    }
    return paths, numbers


def _oscillator_figures(out_dir: Path | None, settings: ValidationSettings, seed: int) -> tuple[list[Path], dict]:
    paths, numbers = [], {}
    for i, (name, model) in enumerate(sorted(PRESETS.items())):
        truth = simulate_oscillator(
            model, settings.oscillator_duration_s, 1.0, np.random.SeedSequence([seed, 3, i]),
            trials=settings.oscillator_trials,
        )
        dev = pooled_oadev(truth.x_s, 1.0)
        theory = adev_theory(model.h, dev.tau_s, 1.0, model.drift_per_s)
        if out_dir is not None:
            paths.append(figures.oscillator_figure(out_dir, name, dev, theory, settings.oscillator_trials,
                                                   settings.oscillator_duration_s))
        inside = (theory >= dev.lo) & (theory <= dev.hi)
        numbers[name] = {
            "seed": [seed, 3, i],
            "trials": settings.oscillator_trials,
            "tau": dev.tau_s,
            "oadev": dev.dev,
            "lo": dev.lo,
            "hi": dev.hi,
            "edf": dev.edf,
            "alpha": dev.alpha,
            "theory": theory,
            "ratio_sim_to_theory": dev.dev / theory,
            "theory_inside_ci": inside,
            "source": model.source,
        }
    return paths, numbers


def _cs_figures(out_dir: Path | None, stab: Path) -> tuple[list[Path], dict]:
    x = read_record(stab / "Cs5071A" / "5071A_phase.txt.gz", kind="phase", rate_hz=1.0).values
    paths, numbers = [], {"n_points": int(x.size)}
    cases = (("mtie", "mtie_decade.txt", "MTIE (s)"), ("tdev", "tdev_decade.txt", "TDEV (s)"))
    for metric, table_name, ylabel in cases:
        table = read_stable32_table(stab / "Cs5071A" / table_name)
        dev = st.compute(metric, x, 1.0, table["tau"])
        if out_dir is not None:
            paths.append(figures.mask_figure(out_dir, metric, dev, table, x.size, ylabel))
        checks = {clock: MASKS[clock].check(dev) for clock in figures.PRIMARY_CLOCKS}
        numbers[metric] = {
            "ours": dev.to_dict(),
            "stable32": {"tau": table["tau"], "dev": table["dev"], "n": table["n"]},
            "max_rel_diff_to_stable32": _max_rel_diff(dev.dev, table["dev"]),
            "masks": {
                clock: {"limit": r.limit_s, "passed": r.passed, "worst_margin_s": r.worst_margin_s,
                        "failed_tau": r.tau_s[r.evaluated & ~r.passed_each]}
                for clock, r in checks.items()
            },
        }
    return paths, numbers


def shipped_data() -> Path:
    """The records :func:`run_validation` reads by default: the package's own ``data`` folder (``stability/gps``
    and ``stability/Cs5071A``, shipped with every installation)."""
    return Path(str(resources.files("chronofuse") / "data"))


def run_validation(data_dir=None, out_dir=None, *, quick: bool = False, seed: int = SEED,
                   progress=None) -> tuple[dict, list[Path]]:
    """Compute every validation number; with ``out_dir`` also write the PNGs and ``validation.json`` there.

    Returns ``(numbers, paths)``: the numbers (:func:`chronofuse.experiments.validation_checks.checks` turns
    them into verdicts) and the files written (none without ``out_dir``: nothing is written unless asked).

    Parameters
    ----------
    data_dir : str or Path, optional
        A folder holding ``stability/gps`` and ``stability/Cs5071A``; default :func:`shipped_data`.
    out_dir : str or Path, optional
        Folder for the figures and ``validation.json`` (created if missing).
    quick : bool
        Use :data:`QUICK` sizes instead of :data:`FULL`.
    seed : int
        Root seed of the simulations.
    progress : callable, optional
        Called with the name of each part as it starts.
    """
    data_dir = shipped_data() if data_dir is None else Path(data_dir)
    stab = data_dir / "stability"
    if not (stab / "gps").is_dir() or not (stab / "Cs5071A").is_dir():
        raise InputError(f"{{data_dir}} == {str(data_dir)!r}, must hold stability/gps and stability/Cs5071A",
                         fields=("data_dir",))
    check_scalar(seed, "seed", min_val=0, integer=True)
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
    settings = QUICK if quick else FULL
    timings, paths, numbers = {}, [], {"settings": settings.__dict__, "quick": bool(quick), "seed": seed}
    gps_x = read_record(stab / "gps" / "gps_1pps_phase_data.txt.gz", kind="phase", rate_hz=1.0).values
    for k, (key, run) in enumerate((
        ("gps", lambda: _gps_figures(out_dir, stab, gps_x, settings)),
        ("receiver", lambda: _receiver_figure(out_dir, stab, gps_x, settings, seed)),
        ("oscillators", lambda: _oscillator_figures(out_dir, settings, seed)),
        ("cs5071a", lambda: _cs_figures(out_dir, stab)),
    )):
        if progress is not None:
            progress(key, k / 4)
        start = time.perf_counter()
        new_paths, numbers[key] = run()
        timings[key] = time.perf_counter() - start
        paths.extend(new_paths)
    numbers["seconds"] = timings
    if out_dir is not None:
        json_path = out_dir / "validation.json"
        json_path.write_text(dumps(numbers) + "\n")
        paths.append(json_path)
    return numbers, paths


def write_validation_figures(out_dir, data_dir=None, *, quick: bool = False, seed: int = SEED) -> list[Path]:
    """Write the validation PNGs and ``validation.json`` into ``out_dir``; return their paths
    (:func:`run_validation` with an output folder)."""
    return run_validation(data_dir, out_dir, quick=quick, seed=seed)[1]
