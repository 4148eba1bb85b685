"""``chronofuse reproduce integrity``: evidence for the HOD chi-square detector against its baselines.

Three experiments on simulated receiver clock biases under the detector's own noise model
(:mod:`chronofuse.integrity.simulate`), all from one ``SeedSequence``:

1. **False-alarm rate.** Empirical P_fa against nominal (1e-1 .. 1e-4) for the HOD detector and the
   baselines with known noise. Two counts: every epoch after start-up (correlated neighbours), and only
   test epochs ``window + 2`` apart, whose windows share no correlated difference (``r(tau >= 3) = 0``),
   so those alarms are independent Bernoulli trials and get an exact 99 % Clopper-Pearson interval.
2. **Noise estimated from training data.** The HOD detector fitted on ``L`` anomaly-free epochs
   (:meth:`HodDetector.fit`), then run on fresh H0 data: the spread of its empirical P_fa against ``L``.
3. **Detection.** Step, ramp (frequency step), quadratic drag-off and noise burst injected at a fixed
   onset, sizes in units of the difference noise ``sigma_df = sqrt(r(0))``: detection probability within a
   horizon after onset and the median delay of the first alarm, per detector.

Outputs (``out_dir``): ``pfa.png``, ``training.png``, ``detection_<kind>.png``, ``pfa.csv``,
``detection.csv``, ``summary.json`` and ``README.md``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.analysis.metrics import clopper_pearson
from chronofuse.estimation.interface import Estimator, pick_inputs
from chronofuse.integrity.baselines import CusumDetector, ReferenceClockDetector, SingleEpochDetector
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.inject import KINDS, SIZE_FIELDS, Anomaly, inject
from chronofuse.integrity.noise_model import noise_intensities
from chronofuse.integrity.result import DetectionResult
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.progress import Progress, silent, stages
from chronofuse.report.integrity import REPORT_FILES, write_integrity_report
from chronofuse.validation import check_scalar


PFAS = (1e-1, 1e-2, 1e-3, 1e-4)
#: The detectors compared, by report name: the high-order-difference chi-square test and its baselines
#: (a single-epoch threshold on the difference, CUSUM, comparison with a reference clock).
DETECTORS = ("hod-chi2", "single-epoch", "cusum", "reference-clock")
FIT_METHODS = ("whittle", "autocorrelation")
SIZES_SIGMA = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0)


@dataclass(frozen=True)
class IntegrityConfig:
    """Experiment settings. Noise: a TCXO-class receiver clock (ADEV 1e-9 at 1 s) and 1 m pseudorange noise."""

    noise: ClockNoise = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
    interval_s: float = 1.0
    window: int = 20
    sigma_reference_s: float = 1e-9
    pfa_trials: int = 500
    pfa_steps: int = 20_000
    training_lengths: tuple[int, ...] = (100, 1_000, 10_000, 100_000)
    training_repeats: int = 20
    training_test_trials: int = 50
    training_test_steps: int = 10_000
    detection_pfa: float = 1e-3
    detection_trials: int = 400
    onset: int = 200
    horizon: int = 60
    seed: int = 20_260_402

    @classmethod
    def quick(cls) -> IntegrityConfig:
        return cls(pfa_trials=300, pfa_steps=10_000, training_lengths=(100, 1_000, 10_000), training_repeats=12,
                   training_test_trials=20, training_test_steps=5_000, detection_trials=200)


def _detectors(cfg: IntegrityConfig, pfa: float) -> dict[str, Estimator]:
    """The four detectors, fitted with the known noise, by their report name."""
    kw = dict(interval_s=cfg.interval_s, pfa=pfa, h0=cfg.noise.h0, hm2=cfg.noise.hm2, sigma_rho_m=cfg.noise.sigma_rho_m)
    s2 = noise_intensities(cfg.noise.h0, cfg.noise.hm2, cfg.noise.sigma_rho_m)[2]
    return {
        "hod-chi2": HodDetector(window=cfg.window, **kw).fit(),
        "single-epoch": SingleEpochDetector(**kw).fit(),
        "cusum": CusumDetector(window=cfg.window, **kw).fit(),
        "reference-clock": ReferenceClockDetector(interval_s=cfg.interval_s, window=cfg.window, pfa=pfa,
                                            sigma_s=math.sqrt(s2 + cfg.sigma_reference_s**2), offset_s=0.0).fit(),
    }


def _run(det: Estimator, measured: np.ndarray, reference: np.ndarray) -> DetectionResult:
    """Any detector through the one interface: it gets the reference reading only if it declares that input."""
    return det.run(measured, **pick_inputs(det, reference_s=reference))


def _simulate(cfg: IntegrityConfig, trials: int, steps: int, seed: np.random.SeedSequence):
    sim_seed, ref_seed = seed.spawn(2)
    sim = simulate_clock_bias(cfg.noise, interval_s=cfg.interval_s, steps=steps, trials=trials, seed=sim_seed)
    rng = np.random.default_rng(ref_seed)
    reference = sim.truth_s + cfg.sigma_reference_s * rng.standard_normal(sim.truth_s.shape)
    return sim, reference


def independent_epochs(steps: int, window: int, start: int) -> np.ndarray:
    """Test epochs ``window + 2`` apart from ``start``: their windows of differences are uncorrelated."""
    return np.arange(start, steps, window + 2)


def false_alarm_rates(cfg: IntegrityConfig, seed: np.random.SeedSequence, say: Progress) -> list[dict]:
    sim, reference = _simulate(cfg, cfg.pfa_trials, cfg.pfa_steps, seed)
    start = cfg.window + 2
    test = independent_epochs(cfg.pfa_steps, cfg.window, start + 100)
    rows = []
    for i, pfa in enumerate(PFAS):
        say(f"false alarms at P_fa {pfa:g}", i / len(PFAS))
        for name, det in _detectors(cfg, pfa).items():
            alarm = _run(det, sim.measured_s, reference).alarm
            k = int(alarm[:, test].sum())
            n = alarm.shape[0] * test.size
            lo, hi = clopper_pearson(k, n)
            rows.append({"detector": name, "pfa": pfa, "rate_all_epochs": float(alarm[:, start + 100:].mean()),
                         "alarms_independent": k, "n_independent": n, "rate_independent": k / n,
                         "ci99_lo": lo, "ci99_hi": hi, "nominal_in_ci99": bool(lo <= pfa <= hi)})
    return rows


def training_effect(cfg: IntegrityConfig, seed: np.random.SeedSequence, say: Progress) -> list[dict]:
    pfa = cfg.detection_pfa
    test_seed, *train_seeds = seed.spawn(1 + len(cfg.training_lengths))
    test, _ = _simulate(cfg, cfg.training_test_trials, cfg.training_test_steps, test_seed)
    rows = []
    for i, (length, tseed) in enumerate(zip(cfg.training_lengths, train_seeds)):
        say(f"training on {length} epochs", i / len(cfg.training_lengths))
        train = simulate_clock_bias(cfg.noise, interval_s=cfg.interval_s, steps=length, trials=cfg.training_repeats,
                                    seed=tseed).measured_s
        for method in FIT_METHODS:
            rates = []
            for row in train:
                det = HodDetector(interval_s=cfg.interval_s, window=cfg.window, pfa=pfa).fit(row, method=method)
                rates.append(float(det.run(test.measured_s).alarm[:, cfg.window + 2:].mean()))
            rates = np.array(rates)
            rows.append({"method": method, "training_epochs": length, "pfa": pfa,
                         "median_rate": float(np.median(rates)), "p10_rate": float(np.quantile(rates, 0.1)),
                         "p90_rate": float(np.quantile(rates, 0.9)), "max_ratio": float(rates.max() / pfa),
                         "min_ratio": float(rates.min() / pfa)})
    return rows


def anomaly_of_size(kind: str, multiple: float, sigma_df: float, cfg: IntegrityConfig) -> Anomaly:
    """An anomaly whose effect on ``df`` is ``multiple`` times ``sigma_df``: a step of ``m sigma_df t_s`` (s),
    a frequency step of ``m sigma_df`` (s/s), a drag of ``m sigma_df / t_s`` (s/s^2) or a burst of
    ``m sigma_df t_s`` (s)."""
    ts = cfg.interval_s
    size = {"step": multiple * sigma_df * ts, "ramp": multiple * sigma_df, "drag": multiple * sigma_df / ts,
            "burst": multiple * sigma_df * ts}[kind]
    return Anomaly(kind, cfg.onset * ts, **{SIZE_FIELDS[kind][0]: size})


def detection_performance(cfg: IntegrityConfig, seed: np.random.SeedSequence, say: Progress) -> list[dict]:
    dets = _detectors(cfg, cfg.detection_pfa)
    sigma_df = math.sqrt(dets["hod-chi2"].r_[0])
    steps = cfg.onset + cfg.horizon
    rows = []
    kind_seeds = seed.spawn(len(KINDS))
    for i, (kind, kseed) in enumerate(zip(KINDS, kind_seeds)):
        say(f"detection of {kind}", i / len(KINDS))
        for multiple, sseed in zip(SIZES_SIGMA, kseed.spawn(len(SIZES_SIGMA))):
            sim_seed, burst_seed = sseed.spawn(2)
            sim, reference = _simulate(cfg, cfg.detection_trials, steps, sim_seed)
            anomaly = anomaly_of_size(kind, multiple, sigma_df, cfg)
            measured = inject(sim.measured_s, anomaly, cfg.interval_s, np.random.default_rng(burst_seed))
            for name, det in dets.items():
                first = _run(det, measured, reference).first_alarm(cfg.onset)
                hit = first >= 0
                delay = (first[hit] - cfg.onset) * cfg.interval_s
                rows.append({"kind": kind, "size_sigma": multiple, "size": anomaly.magnitude, "detector": name,
                             "p_detect": float(hit.mean()),
                             "median_delay_s": float(np.median(delay)) if delay.size else math.nan})
    return rows


#: Seconds per detector-epoch of each stage of :func:`run_integrity` and of its figures (only the ratios
#: matter), measured on ``chronofuse reproduce integrity --quick`` on a loaded 2-core machine: false alarms
#: 8.9 s, training 8.9 s, detection 2.8 s, figures 5.1 s.
STAGE_S_PER_UNIT = (8.9 / (4 * 4 * 300 * 10_000), 8.9 / (3 * 2 * 12 * 20 * 5_000), 2.8 / (4 * 11 * 4 * 200 * 260), 5.1)


def run_integrity(out_dir: str | Path, *, quick: bool = False, progress: Progress | None = None,
                  config: IntegrityConfig | None = None, seed: int | None = None) -> dict:
    """Run the three experiments; :func:`chronofuse.report.integrity.write_integrity_report` writes the figures,
    tables, ``summary.json`` and ``README.md`` to ``out_dir``. ``seed`` replaces the configuration's (None:
    the published run's, :attr:`IntegrityConfig.seed`).

    Returns the summary dictionary (also written as JSON).
    """
    cfg = config or (IntegrityConfig.quick() if quick else IntegrityConfig())
    if seed is not None:
        cfg = dataclasses.replace(cfg, seed=check_scalar(seed, "seed", min_val=0, integer=True))
    out = Path(out_dir)
    # the stages' expected seconds: their detector-epochs (each detector's run over trials x steps; a training
    # fit counts as one run over the test record) times the rates of STAGE_S_PER_UNIT, and the figures
    work = [len(PFAS) * len(DETECTORS) * cfg.pfa_trials * cfg.pfa_steps,
            len(cfg.training_lengths) * len(FIT_METHODS) * cfg.training_repeats * cfg.training_test_trials
            * cfg.training_test_steps,
            len(KINDS) * len(SIZES_SIGMA) * len(DETECTORS) * cfg.detection_trials * (cfg.onset + cfg.horizon), 1]
    pfa_say, train_say, det_say, figure_say = stages(progress or silent, [w * r for w, r in zip(work, STAGE_S_PER_UNIT)])
    pfa_seed, train_seed, det_seed = np.random.SeedSequence(cfg.seed).spawn(3)
    pfa_rows = false_alarm_rates(cfg, pfa_seed, pfa_say)
    training_rows = training_effect(cfg, train_seed, train_say)
    detection_rows = detection_performance(cfg, det_seed, det_say)
    min_size = {}
    for kind in KINDS:
        min_size[kind] = {}
        for name in DETECTORS:
            ok = [r["size_sigma"] for r in detection_rows if r["kind"] == kind and r["detector"] == name
                  and r["p_detect"] >= 0.9]
            min_size[kind][name] = min(ok) if ok else None
    summary = {"quick": quick, "seed": cfg.seed, "window": cfg.window, "interval_s": cfg.interval_s,
               "noise": {"h0": cfg.noise.h0, "hm2": cfg.noise.hm2, "sigma_rho_m": cfg.noise.sigma_rho_m},
               "false_alarms": pfa_rows, "training": training_rows, "detection": detection_rows,
               "min_size_p90": min_size, "files": list(REPORT_FILES)}
    figure_say("figures")
    write_integrity_report(out, summary, cfg, DETECTORS, PFAS)
    return summary
