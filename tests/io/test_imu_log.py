"""The IMU CSV reader: columns and units, bad input named, and blocks that drive the GNSS/INS filters exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.io.imu_log import imu_blocks, read_imu_csv, write_imu_csv
from chronofuse.models.imu import imu_grade
from chronofuse.positioning.loose import LooselyCoupled, smooth
from chronofuse.positioning.scenario import simulate_drive
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError

START = 1_400_000_000 * NS_PER_S


def _drive():
    return simulate_drive("open-sky", "gps", "industrial", 60.0, 1, seed=4)


def _log_of(drive, path):
    gyro = drive.gyro_rad_per_s[0].reshape(-1, 3)
    accel = drive.accel_m_per_s2[0].reshape(-1, 3)
    dt = NS_PER_S // int(drive.imu_rate_hz)
    t = START + dt * np.arange(1, gyro.shape[0] + 1)  # sample k ends at (k + 1) dt
    write_imu_csv(path, t, gyro, accel)
    epochs = START + NS_PER_S * np.arange(1, drive.gyro_rad_per_s.shape[1] + 1)
    return epochs


def test_a_log_written_and_read_back_drives_the_filter_and_smoother_to_the_same_numbers(tmp_path):
    drive = _drive()
    epochs = _log_of(drive, tmp_path / "imu.csv")
    log = read_imu_csv(tmp_path / "imu.csv")
    gyro, accel = imu_blocks(log, epochs)
    assert log.rate_hz == pytest.approx(100.0) and gyro.shape == drive.gyro_rad_per_s.shape[1:]
    np.testing.assert_array_equal(gyro, drive.gyro_rad_per_s[0])
    t = drive.truth
    filt = LooselyCoupled(imu_grade("industrial"), t.lat_lon_h[0, 0], t.v_ned_m_per_s[0, 0], t.c_bn[0, 0], 100.0,
                          sigma_r_m=1.0, sigma_v_m_per_s=0.1).fit()
    a = filt.run(drive.fix_lat_lon_h, gyro_rad_per_s=drive.gyro_rad_per_s, accel_m_per_s2=drive.accel_m_per_s2,
                 fix_cov_ned_m2=drive.fix_cov_ned_m2)
    b = filt.run(drive.fix_lat_lon_h, gyro_rad_per_s=gyro[None], accel_m_per_s2=accel[None],
                 fix_cov_ned_m2=drive.fix_cov_ned_m2)
    np.testing.assert_array_equal(a.lat_lon_h, b.lat_lon_h)
    np.testing.assert_array_equal(smooth(a), smooth(b))


def test_degrees_and_g_columns_are_converted(tmp_path):
    path = tmp_path / "units.csv"
    rows = ["t_s,gyro_x_deg_per_s,gyro_y_deg_per_s,gyro_z_deg_per_s,accel_x_g,accel_y_g,accel_z_g"]
    rows += [f"{k * 0.01:.2f},180,0,-90,0,0,-1" for k in range(5)]
    path.write_text("\n".join(rows) + "\n")
    log = read_imu_csv(path, start_gps_ns=START)
    assert log.gyro_rad_per_s[0] == pytest.approx([math.pi, 0.0, -math.pi / 2])
    assert log.accel_m_per_s2[0, 2] == pytest.approx(-9.80665) and log.gps_ns[1] - log.gps_ns[0] == 10_000_000


@pytest.mark.parametrize("text,message", [
    ("t_s,gyro_x_rad_per_s\n0,1\n", "start_gps_ns"),
    ("gps_ns,gyro_x_rad_per_s,gyro_y_rad_per_s,gyro_z_rad_per_s\n1,0,0,0\n2,0,0,0\n", "accel"),
    ("gps_ns,gyro_x_rad_per_s,gyro_y_rad_per_s,gyro_z_rad_per_s,accel_x_m_per_s2,accel_y_m_per_s2,accel_z_m_per_s2\n"
     "10,0,0,0,0,0,0\n20,0,,0,0,0,0\n", "line 3: no value in column gyro_y_rad_per_s"),
    ("gps_ns,gyro_x_rad_per_s,gyro_y_rad_per_s,gyro_z_rad_per_s,accel_x_m_per_s2,accel_y_m_per_s2,accel_z_m_per_s2\n"
     "10,0,0,0,0,0,0\n20,0,0,0,0,0,0\n30,0,0,0,0,0,0\n50,0,0,0,0,0,0\n", "line 5: sample interval"),
])
def test_bad_logs_are_refused_naming_what_is_wrong(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputDataError, match=message) as err:
        read_imu_csv(path)
    assert "bad.csv" in str(err.value)


def test_epochs_off_the_imu_samples_are_refused(tmp_path):
    drive = _drive()
    epochs = _log_of(drive, tmp_path / "imu.csv")
    log = read_imu_csv(tmp_path / "imu.csv")
    with pytest.raises(InputDataError, match="whole number"):
        imu_blocks(log, epochs[:10] + np.arange(10) * 5_000_000)
    with pytest.raises(InputDataError, match="does not hold a sample"):
        imu_blocks(log, epochs - 3_000_000)


_HEADER = "gps_ns,gyro_x_rad_per_s,gyro_y_rad_per_s,gyro_z_rad_per_s,accel_x_m_per_s2,accel_y_m_per_s2,accel_z_m_per_s2"


def _csv(path, rows, header=_HEADER):
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _rows(n=5, gyro="0.001", accel="0.1", t0=1_400_000_000_000_000_000):
    return [f"{t0 + k * 10_000_000},{gyro},0,0,{accel},0,-9.81" for k in range(n)]


def _refused(path) -> str:
    with pytest.raises(InputDataError) as info:
        read_imu_csv(path)
    return str(info.value)


def test_text_in_a_numeric_column_is_an_input_error_naming_line_and_column(tmp_path):
    rows = _rows()
    rows[2] = rows[2].replace(",0.1,", ",abc,")
    message = _refused(_csv(tmp_path / "t.csv", rows))
    assert "line 4" in message and "accel_x_m_per_s2" in message and "'abc'" in message


def test_a_missing_gps_ns_is_an_error_naming_its_line_without_a_runtime_warning(tmp_path):
    rows = _rows()
    rows[3] = "," + rows[3].split(",", 1)[1]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        message = _refused(_csv(tmp_path / "m.csv", rows))
    assert "line 5" in message and "no value in column gps_ns" in message


def test_a_float_gps_ns_is_refused_as_one(tmp_path):
    rows = [r.replace("1400000000", "1.4e18,", 1).split(",", 1)[0] + "," + r.split(",", 1)[1] for r in _rows()]
    message = _refused(_csv(tmp_path / "f.csv", rows))
    assert "line 2" in message and "must be an integer number of nanoseconds" in message


def test_both_units_of_the_gyro_are_refused_and_one_is_read(tmp_path):
    header = _HEADER + ",gyro_x_deg_per_s,gyro_y_deg_per_s,gyro_z_deg_per_s"
    rows = [r + ",57.3,0,0" for r in _rows(gyro="0.5")]
    message = _refused(_csv(tmp_path / "both.csv", rows, header))
    assert "gyro_x/y/z_rad_per_s and gyro_x/y/z_deg_per_s" in message
    deg = header.replace("gyro_x_rad_per_s,gyro_y_rad_per_s,gyro_z_rad_per_s,", "")
    only = [",".join(r.split(",")[:1] + r.split(",")[4:]) for r in rows]
    log = read_imu_csv(_csv(tmp_path / "deg.csv", only, deg))
    assert log.gyro_rad_per_s[0, 0] == pytest.approx(math.radians(57.3))


@pytest.mark.parametrize("gyro, accel, word", [("1e308", "0.1", "gyro_x_rad_per_s"), ("0.001", "1e300", "accel_x"),
                                               ("101", "0.1", "100 rad/s"), ("0.001", "2001", "2000 m/s^2")])
def test_implausible_samples_are_refused_naming_the_limit(tmp_path, gyro, accel, word):
    message = _refused(_csv(tmp_path / "huge.csv", _rows(gyro=gyro, accel=accel)))
    assert "line 2" in message and "beyond the plausible" in message and word in message


def test_samples_at_the_limits_are_read(tmp_path):
    log = read_imu_csv(_csv(tmp_path / "edge.csv", _rows(gyro="99.9", accel="1999")))
    assert log.gyro_rad_per_s[0, 0] == 99.9 and log.accel_m_per_s2[0, 0] == 1999.0
