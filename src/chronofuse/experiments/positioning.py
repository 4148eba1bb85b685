"""GNSS-only, GNSS/INS and smoothed solutions of the same simulated drive, side by side (the GNSSDO paper section 6.3).

Orchestration only: the drive (:mod:`chronofuse.positioning.scenario`), the filter and smoother
(:mod:`chronofuse.positioning.loose`), the metrics (:mod:`chronofuse.analysis.metrics`) and the figures
(:mod:`chronofuse.report.positioning`). Trials run in chunks (each a whole vectorized batch) so memory stays
bounded; trial ``i`` draws the same numbers whatever the chunking.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.analysis.metrics import horizontal_cep_m, outage_bridging_s, vertical_95_m
from chronofuse.gnss.simulate import ENVIRONMENTS
from chronofuse.io.rinex import read_gps_navigation
from chronofuse.models.imu import IMU_GRADES, ImuModel, imu_grade
from chronofuse.positioning.errors import ned_difference_m
from chronofuse.positioning.loose import LooselyCoupled, smooth
from chronofuse.positioning.scenario import SYSTEMS, simulate_drive
from chronofuse.validation import check_choice, check_scalar

__all__ = ["PositioningConfig", "run_positioning", "INS_CHOICES", "PAPER_CLAIMS", "solution_metrics"]

INS_CHOICES = ("none", *IMU_GRADES)
_CHUNK_TRIALS = 10

#: The GNSSDO paper section 6.3's positioning claims (GPS+BDS+INS with fixed-interval smoothing).
PAPER_CLAIMS = {"cep95_before_m": 4.2, "cep95_after_m": 0.9, "vertical95_before_m": 6.1, "vertical95_after_m": 1.5,
               "error_at_gdop4_m": 2.0}


@dataclass(frozen=True)
class PositioningConfig:
    """What one ``chronofuse position`` run simulates (options of the command of the same names)."""

    scenario: str = "urban-canyon"
    systems: str = "gps+bds"
    ins: str = "industrial"
    smooth: bool = True
    duration_s: float = 600.0
    trials: int = 10
    seed: int = 0
    imu_rate_hz: float = 100.0
    speed_m_per_s: float = 12.0
    #: An IMU error model to use instead of the named grade (e.g. an error-free one for the physical floor).
    imu_model: ImuModel | None = None
    #: A RINEX navigation file: GPS satellites from its broadcast ephemeris instead of the constellation model.
    nav: str | Path | None = None
    #: A signal environment replacing the scenario's (e.g. a calibrated canyon).
    environment: object | None = None

    def __post_init__(self):
        check_choice(self.scenario, "scenario", ENVIRONMENTS)
        check_choice(self.systems, "systems", SYSTEMS)
        check_choice(self.ins, "ins", INS_CHOICES)
        check_scalar(self.duration_s, "duration_s", min_val=10.0)
        check_scalar(self.trials, "trials", min_val=1, integer=True)
        check_scalar(self.imu_rate_hz, "imu_rate_hz", min_val=10.0)


def solution_metrics(errors_ned_m: np.ndarray, gdop: np.ndarray, outage: np.ndarray) -> dict:
    """CEP50/95, vertical 95 %, availability, error at GDOP about 4, and outage bridging of one solution."""
    horizontal = np.hypot(errors_ned_m[..., 0], errors_ned_m[..., 1])
    near4 = np.isfinite(gdop) & (np.abs(gdop - 4.0) < 0.5)
    return {
        "cep50_m": horizontal_cep_m(errors_ned_m[..., :2], 50), "cep95_m": horizontal_cep_m(errors_ned_m[..., :2], 95),
        "vertical95_m": vertical_95_m(errors_ned_m[..., 2]),
        "availability": float(np.isfinite(horizontal).mean()),
        "horizontal95_at_gdop4_m": (float(np.nanpercentile(horizontal[near4], 95)) if np.isfinite(horizontal[near4]).any()
                                    else float("nan")),
        "bridging_s": outage_bridging_s(np.nan_to_num(horizontal, nan=np.inf), outage, 1.0),
    }


def _chunk(cfg: PositioningConfig, first: int, trials: int, nav) -> dict[str, np.ndarray]:
    imu = cfg.imu_model or imu_grade(cfg.ins if cfg.ins != "none" else "industrial")
    drive = simulate_drive(cfg.scenario, cfg.systems, imu, cfg.duration_s, trials, seed=cfg.seed,
                           imu_rate_hz=cfg.imu_rate_hz, speed_m_per_s=cfg.speed_m_per_s, first_trial=first, nav=nav,
                           environment=cfg.environment)
    truth = np.broadcast_to(drive.truth.lat_lon_h[:, 1:], drive.fix_lat_lon_h.shape)
    out = {"gnss": ned_difference_m(drive.fix_lat_lon_h, truth), "gdop": drive.gdop,
           "truth_lat_lon_h": drive.truth.lat_lon_h[0, 1:]}
    if cfg.ins != "none":
        t = drive.truth
        # The drive starts at a surveyed point, standing still: the INS is aligned there.
        filt = LooselyCoupled(imu, t.lat_lon_h[0, 0], t.v_ned_m_per_s[0, 0], t.c_bn[0, 0],
                              cfg.imu_rate_hz, sigma_r_m=1.0, sigma_v_m_per_s=0.1, sigma_psi_rad=0.01).fit()
        result = filt.run(drive.fix_lat_lon_h, gyro_rad_per_s=drive.gyro_rad_per_s,
                          accel_m_per_s2=drive.accel_m_per_s2, fix_cov_ned_m2=drive.fix_cov_ned_m2)
        out["gnss+ins"] = ned_difference_m(result.lat_lon_h, truth)
        if cfg.smooth:
            out["gnss+ins+rts"] = ned_difference_m(smooth(result), truth)
    return out


def run_positioning(cfg: PositioningConfig, progress: Callable[[str], None] | None = None) -> dict:
    """Run every solution the configuration asks for; returns the summary and the per-epoch errors."""
    nav = read_gps_navigation(cfg.nav) if cfg.nav is not None else None
    parts: list[dict] = []
    for first in range(0, cfg.trials, _CHUNK_TRIALS):
        n = min(_CHUNK_TRIALS, cfg.trials - first)
        if progress is not None:
            progress(f"trials {first + 1}-{first + n} of {cfg.trials}")
        parts.append(_chunk(cfg, first, n, nav))
    errors = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k not in ("gdop", "truth_lat_lon_h")}
    gdop = np.concatenate([p["gdop"] for p in parts])
    outage = ~np.isfinite(errors["gnss"][..., 0]).any(axis=0)
    solutions = {name: solution_metrics(err, gdop, outage) for name, err in errors.items()}
    summary = {
        "scenario": cfg.scenario, "systems": cfg.systems, "satellites": "broadcast" if nav else "model", "ins": cfg.ins, "smooth": cfg.smooth,
        "duration_s": cfg.duration_s, "trials": cfg.trials, "seed": cfg.seed,
        "gdop_mean": float(np.nanmean(gdop)) if np.isfinite(gdop).any() else float("nan"),
        "gdop_over_5_fraction": float(np.mean(~(gdop <= 5.0))),
        "outage_s": float(outage.sum()),
        "solutions": solutions,
    }
    return {"summary": summary, "errors_ned_m": errors, "gdop": gdop, "truth_lat_lon_h": parts[0]["truth_lat_lon_h"]}


def write_report(run: dict, out_dir: str | Path) -> list[Path]:
    """JSON summary, per-epoch CSV of the first trial, and the figures into ``out_dir``."""
    from chronofuse.report.jsonio import dumps
    from chronofuse.report.positioning import plot_errors, plot_outages, plot_trajectory

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(dumps(run["summary"]) + "\n")
    paths = [out / "summary.json", plot_trajectory(run, out / "trajectory.png"), plot_errors(run, out / "errors.png")]
    if run["summary"]["outage_s"] > 0:
        paths.append(plot_outages(run, out / "outages.png"))
    return paths
