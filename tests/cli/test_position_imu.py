"""``chronofuse position --obs ... --imu``: GNSS/INS on a real station with an IMU log of a static antenna.

The log is generated here (:func:`static_log`): a body at rest at the station's published antenna position in
the attitude :data:`ATTITUDE_DEG`, its accelerometers reading the reaction to normal gravity and its gyros
the Earth rate in the body frame (:func:`chronofuse.positioning.ins.static_imu_truth`), plus the white noise
and the turn-on bias of the ``industrial`` grade of :data:`chronofuse.models.imu.IMU_GRADES` (Xsens MTi-1:
0.007 deg/s/sqrt(Hz) and 120 ug/sqrt(Hz); turn-on 0.2 deg/s and 5 mg), at 10 Hz on GPS time.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pymap3d
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.io.imu_log import write_imu_csv
from chronofuse.models.imu import ImuModel, SensorErrors, imu_grade, simulate_imu
from chronofuse.positioning.ins import euler_to_dcm, static_imu_truth
from chronofuse.timescale import NS_PER_S

runner = CliRunner()

#: Roll, pitch, yaw of the body (deg).
ATTITUDE_DEG = (2.0, -1.0, 30.0)
RATE_HZ = 10.0
#: The span of the station analysed: three hours of ESBC at 30 s (360 epochs).
END_S = 10_799
#: The simulation's bound on the horizontal error with three satellites for a minute (docs/positioning).
THREE_SATELLITE_BOUND_M = 6.0


def static_log(station, first_ns: int, seconds: float, seed: int = 21) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(gps_ns, gyro, accel)`` of the static IMU of the module docstring from ``first_ns`` for ``seconds``."""
    grade = imu_grade("industrial")
    model = ImuModel("industrial, white noise and turn-on bias",
                     SensorErrors(grade.gyro.white_density, turn_on_bias=grade.gyro.turn_on_bias),
                     SensorErrors(grade.accel.white_density, turn_on_bias=grade.accel.turn_on_bias), grade.source)
    lat, _, h = pymap3d.ecef2geodetic(*station.reference_arp_m, deg=False)
    steps = int(seconds * RATE_HZ)
    omega, force = static_imu_truth(lat, h, euler_to_dcm(*np.radians(ATTITUDE_DEG)), steps)
    imu = simulate_imu(model, omega, force, RATE_HZ, seed=seed)
    t = first_ns + np.arange(steps, dtype=np.int64) * int(NS_PER_S / RATE_HZ)
    return t, imu.gyro_rad_per_s[0], imu.accel_m_per_s2[0]


@pytest.fixture(scope="module")
def esbc(igs_stations):
    return igs_stations["ESBC"]


@pytest.fixture(scope="module")
def log_path(esbc, tmp_path_factory):
    """The log from 60 s before the first epoch to 60 s after the span's end."""
    first = int(esbc.observations().gps_ns[0])
    t, gyro, accel = static_log(esbc, first - 60 * NS_PER_S, END_S + 120)
    path = tmp_path_factory.mktemp("imu") / "esbc_imu.csv"
    write_imu_csv(path, t, gyro, accel)
    return path


def _args(station, log, end=END_S):
    args = ["position", "--obs", str(station.obs_path), "--systems", "gps+bds", "--imu", str(log), "--end", str(end),
            "--position", ",".join(f"{v:.4f}" for v in station.reference_arp_m)]
    for p in station.nav_paths:
        args += ["--nav", str(p)]
    return args


@pytest.mark.parametrize("coupling", ["loose", "tight"])
def test_gnss_ins_is_no_worse_than_spp_and_smoothing_no_worse_than_filtering(esbc, log_path, tmp_path, coupling):
    out = tmp_path / "out"
    result = runner.invoke(app, _args(esbc, log_path) + ["--coupling", coupling, "--smooth", "--json", "--out", str(out)])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["warnings"] == [] and doc["ins"]["coupling"] == coupling and doc["ins"]["epochs"] == 360
    st = doc["ins"]["statistics"]
    assert st["spp"]["fixes"] == st["ins"]["fixes"] == st["smoothed"]["fixes"] == 360
    assert st["ins"]["horizontal95_m"] <= 1.1 * st["spp"]["horizontal95_m"]
    assert st["smoothed"]["horizontal95_m"] <= st["ins"]["horizontal95_m"]
    # the files: the GNSS/INS solution in SPP's columns, SPP's and the smoothed beside it
    ins, spp = pd.read_csv(out / "positions.csv"), pd.read_csv(out / "spp_positions.csv")
    smoothed = pd.read_csv(out / "smoothed_positions.csv")
    assert list(ins.columns) == list(spp.columns) == list(smoothed.columns) and len(ins) == len(spp) == 360
    for table, name in ((ins, "ins"), (spp, "spp"), (smoothed, "smoothed")):
        assert abs(np.percentile(np.hypot(table["east_m"], table["north_m"]), 95) - st[name]["horizontal95_m"]) < 1e-3
    assert json.loads((out / "summary.json").read_text())["ins"]["statistics"] == st


def test_tight_coupling_with_three_satellites_for_a_minute_keeps_the_bound_where_spp_has_no_fix(esbc, log_path):
    from chronofuse.experiments.real_ins import ins_positions
    from chronofuse.gnss.point_positioning import enu_errors_m, point_positions
    from chronofuse.io.imu_log import read_imu_csv

    obs = esbc.observations()
    obs = obs.select(obs.gps_ns <= obs.gps_ns[0] + 3599 * NS_PER_S)
    fixes = point_positions(obs, esbc.navigation(), ("G", "C"))
    # from 30 min on, for 60 s (three epochs): only the three highest GPS satellites the fixes used (as the
    # simulation keeps its highest), no BDS
    window = np.flatnonzero((obs.gps_ns >= obs.gps_ns[0] + 1800 * NS_PER_S)
                            & (obs.gps_ns <= obs.gps_ns[0] + 1860 * NS_PER_S))
    used = np.isfinite(fixes.residual_m[window[0]])
    gps = [k for k, (s, u) in enumerate(zip(fixes.satellites, used)) if u and s.startswith("G")]
    keep = [fixes.satellites[k] for k in sorted(gps, key=lambda k: -fixes.elevation_rad[window[0], k])[:3]]
    drop = np.array([s not in keep for s in obs.satellites])
    values = {k: v.copy() for k, v in obs.values.items()}
    for v in values.values():
        v[np.ix_(window, np.flatnonzero(drop))] = np.nan
    thinned = replace(obs, values=values)
    spp = point_positions(thinned, esbc.navigation(), ("G", "C"))
    assert np.isnan(spp.position_m[window]).all() and np.isfinite(spp.position_m[window[0] - 1]).all()
    solution = ins_positions(spp, read_imu_csv(log_path), coupling="tight")
    enu = enu_errors_m(solution.filtered[window], esbc.reference_arp_m)
    assert np.hypot(enu[:, 0], enu[:, 1]).max() < THREE_SATELLITE_BOUND_M


def _one_error_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    return lines[0]


def test_a_log_of_another_day_is_refused_naming_it(esbc, log_path, tmp_path):
    frame = pd.read_csv(log_path, dtype={"gps_ns": "int64"})
    frame["gps_ns"] += 86_400 * NS_PER_S
    other = tmp_path / "another_day.csv"
    frame.to_csv(other, index=False)
    line = _one_error_line(runner.invoke(app, _args(esbc, other, end=600)))
    assert "another_day.csv" in line and "do not overlap the observation epochs" in line


def test_a_log_with_a_gap_warns_of_it_and_still_solves(esbc, log_path, tmp_path):
    frame = pd.read_csv(log_path, dtype={"gps_ns": "int64"})
    first = int(frame["gps_ns"].iloc[0])
    gap = (frame["gps_ns"] > first + 300 * NS_PER_S) & (frame["gps_ns"] <= first + 305 * NS_PER_S)
    gapped = tmp_path / "gapped.csv"
    frame[~gap].to_csv(gapped, index=False)
    result = runner.invoke(app, _args(esbc, gapped, end=1199) + ["--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert len(doc["warnings"]) == 1 and "gapped.csv: 1 gap in the IMU samples (50 missing" in doc["warnings"][0]
    assert "the longest 5 s" in doc["warnings"][0] and doc["ins"]["gaps"] == 1 and doc["ins"]["epochs"] == 40


@pytest.mark.parametrize("extra, named", [
    (["--coupling", "medium"], "--coupling == 'medium'"), (["--ins", "none"], "--ins == 'none'"),
    (["--imu-rate", "100"], "--imu-rate"),
])
def test_bad_ins_options_are_one_line_errors_naming_them(esbc, log_path, extra, named):
    line = _one_error_line(runner.invoke(app, _args(esbc, log_path, end=300) + extra))
    assert named in line


def test_the_ins_options_need_the_imu_log_with_obs(esbc):
    args = [a for a in _args(esbc, "x", end=300)]
    i = args.index("--imu")
    del args[i:i + 2]
    line = _one_error_line(runner.invoke(app, args + ["--coupling", "tight"]))
    assert "--coupling" in line and "--imu" in line


def _moved(log_path, tmp_path, name, first_s, change):
    """The log with ``change(frame, rows)`` applied to its samples from the first epoch for ``first_s`` s."""
    frame = pd.read_csv(log_path, dtype={"gps_ns": "int64"})
    t0 = int(frame["gps_ns"].iloc[0]) + 60 * NS_PER_S  # the first epoch: the INS start
    rows = (frame["gps_ns"] >= t0) & (frame["gps_ns"] < t0 + int(first_s * NS_PER_S))
    change(frame, rows)
    out = tmp_path / name
    frame.to_csv(out, index=False, float_format="%.10g")
    return out


def _roll(rate):
    def change(frame, rows):
        k = np.arange(int(rows.sum())) / RATE_HZ
        # rolling at ``rate`` about x: the measured rate, and gravity turning in the body's y-z plane
        frame.loc[rows, "gyro_x_rad_per_s"] += rate
        a = rate * k
        y, z = frame.loc[rows, "accel_y_m_per_s2"].to_numpy(), frame.loc[rows, "accel_z_m_per_s2"].to_numpy()
        frame.loc[rows, "accel_y_m_per_s2"] = np.cos(a) * y + np.sin(a) * z
        frame.loc[rows, "accel_z_m_per_s2"] = -np.sin(a) * y + np.cos(a) * z
    return change


def _move(frame, rows):
    k = np.arange(int(rows.sum())) / RATE_HZ
    frame.loc[rows, "gyro_z_rad_per_s"] += 0.3
    frame.loc[rows, "accel_x_m_per_s2"] += 1.5 * np.sin(k)


def _in_g(frame, rows):
    for ax in "xyz":
        frame[f"accel_{ax}_m_per_s2"] /= 9.80665


@pytest.mark.parametrize("name, change, said", [
    ("rolling.csv", _roll(0.05), "mean angular rate"), ("rolling_slowly.csv", _roll(0.005), "varies by"),
    ("moving.csv", _move, "mean angular rate"), ("in_g.csv", _in_g, "in g under _m_per_s2 columns?"),
])
def test_a_log_not_at_rest_at_the_ins_start_is_refused_naming_it(esbc, log_path, tmp_path, name, change, said):
    moved = _moved(log_path, tmp_path, name, 20, change)
    line = _one_error_line(runner.invoke(app, _args(esbc, moved, end=300)))
    assert name in line and said in line and "at rest" in line and "NaN" not in line


def test_a_log_moving_before_the_ins_start_only_is_accepted(esbc, log_path, tmp_path):
    """The window is the INS start's, not the log's first seconds (here a minute before the first epoch)."""
    frame = pd.read_csv(log_path, dtype={"gps_ns": "int64"})
    early = frame["gps_ns"] < int(frame["gps_ns"].iloc[0]) + 30 * NS_PER_S
    _move(frame, early)
    out = tmp_path / "moved_early.csv"
    frame.to_csv(out, index=False, float_format="%.10g")
    result = runner.invoke(app, _args(esbc, out, end=300) + ["--json"])
    assert result.exit_code == 0, result.output


def test_a_log_below_ten_hertz_is_refused_naming_it_and_its_rate(esbc, log_path, tmp_path):
    frame = pd.read_csv(log_path, dtype={"gps_ns": "int64"})
    slow = tmp_path / "one_hertz.csv"
    frame.iloc[::10].to_csv(slow, index=False, float_format="%.10g")
    line = _one_error_line(runner.invoke(app, _args(esbc, slow, end=300)))
    assert "one_hertz.csv" in line and "1 Hz" in line and "--imu-rate" not in line
