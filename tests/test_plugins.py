"""Plugins: a package installed with pip registers a servo and a detector through entry points, and
``chronofuse gnssdo --controller NAME`` and ``chronofuse detect --detector NAME`` run them.

The package is ``tests/data/plugins/chronofuse-example-plugin`` (its own pyproject.toml); the test builds a
wheel of its files (a zip with the package and its dist-info: no build backend needed) and installs it with
``pip install --target`` into a temporary folder, which the command-line runs get on PYTHONPATH.
"""

from __future__ import annotations

import base64
import csv
import hashlib
import json
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

from chronofuse.discipline.registry import SERVOS
from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.integrity.registry import DETECTORS
from chronofuse.registry import PluginError

PLUGIN = Path(__file__).resolve().parent / "data" / "plugins" / "chronofuse-example-plugin"
CHRONOFUSE = Path(sys.executable).with_name("chronofuse")


def _wheel(folder: Path) -> Path:
    """A wheel (PEP 427) of the plugin's source files, its entry points read from its pyproject.toml."""
    project = tomllib.loads((PLUGIN / "pyproject.toml").read_text())["project"]
    name, version = project["name"].replace("-", "_"), project["version"]
    dist = f"{name}-{version}.dist-info"
    entry_points = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()) + "\n"
                           for group, points in project["entry-points"].items())
    files = {str(p.relative_to(PLUGIN)): p.read_bytes() for p in sorted(PLUGIN.rglob("*.py"))}
    files[f"{dist}/METADATA"] = f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {version}\n".encode()
    files[f"{dist}/WHEEL"] = b"Wheel-Version: 1.0\nGenerator: tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n"
    files[f"{dist}/entry_points.txt"] = entry_points.encode()
    record = [f"{path},sha256={base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b'=').decode()},"
              f"{len(data)}" for path, data in files.items()] + [f"{dist}/RECORD,,"]
    files[f"{dist}/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = folder / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as zf:
        for path, data in files.items():
            zf.writestr(path, data)
    return wheel


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The folder pip installed the plugin into."""
    work = tmp_path_factory.mktemp("plugin")
    target = work / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", "--target",
                    str(target), str(_wheel(work))], check=True)
    return target


@pytest.fixture
def on_path(installed, monkeypatch):
    """The plugin importable in this process; the registries forget it again afterwards."""
    monkeypatch.syspath_prepend(str(installed))
    for registry in (SERVOS, DETECTORS):
        registry.refresh()
    yield installed
    monkeypatch.undo()
    for registry in (SERVOS, DETECTORS):
        registry.refresh()


def _run(installed: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(installed)}
    return subprocess.run([str(CHRONOFUSE), *args], capture_output=True, text=True, env=env, timeout=600)


def _clock_bias_csv(path: Path, step_at: int | None) -> Path:
    rng = np.random.default_rng(4)
    n = 1200
    # a receiver clock with a frequency offset, white FM and white phase noise: stationary first differences
    bias = 2e-4 + 1e-8 * np.arange(n) + np.cumsum(2e-10 * rng.standard_normal(n)) + 3e-9 * rng.standard_normal(n)
    if step_at is not None:
        bias[step_at:] += 2e-7
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["time_s", "clock_bias_s"])
        writer.writerows((k, f"{b:.12e}") for k, b in enumerate(bias))
    return path


def test_an_installed_plugin_adds_its_servo_and_detector_to_the_registries(on_path):
    assert "example-p" in SERVOS.names() and "example-jump" in DETECTORS.names()
    assert "example-p" not in SERVOS.builtin_names()
    servo = SERVOS.create("example-p", context={"interval_s": 1.0, "dac": None}, kp=0.2)
    assert type(servo).__module__ == "chronofuse_example_plugin.servo" and servo.kp == 0.2
    z = np.cumsum(1e-9 * np.random.default_rng(1).standard_normal((2, 300)), axis=1)
    z[:, 50:60] = np.nan
    assert compare_streaming_to_batch(servo, z, rtol=0.0) == []
    twin = SERVOS.create("example-p", context={"interval_s": 1.0}, kp=0.2)
    twin.fast = False
    np.testing.assert_array_equal(servo.run(z).freq_adj, twin.run(z).freq_adj)
    with pytest.raises(ValueError, match="steer_s is not a setting of servos member 'example-p'"):
        SERVOS.create("example-p", steer_s=10.0)
    detector = DETECTORS.create("example-jump", context={"interval_s": 1.0}).fit(z[0, :40])
    assert compare_streaming_to_batch(detector, z, rtol=1e-12) == []


def test_chronofuse_gnssdo_runs_the_plugin_servo_named_by_controller(installed):
    done = _run(installed, "gnssdo", "--controller", "example-p", "--duration", "3600", "--json")
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["controller"] == "example-p"
    # a proportional loop holds the phase, with an offset of its own, far inside the 5e-4 s start offsets
    assert summary["time_error_rms_ns"] < 1e3
    unknown = _run(installed, "gnssdo", "--controller", "example-q", "--duration", "3600", "--json")
    assert unknown.returncode == 2 and "example-p" in unknown.stderr


def test_chronofuse_detect_runs_the_plugin_detector_named_by_detector(installed, tmp_path):
    stepped = _clock_bias_csv(tmp_path / "stepped.csv", step_at=800)
    done = _run(installed, "detect", str(stepped), "--detector", "example-jump", "--train", "300", "--pfa", "1e-5",
                "--json")
    assert done.returncode == 1, done.stderr
    doc = json.loads(done.stdout)
    assert [a["t_ns"] for a in doc["alarms"]] == [800_000_000_000]
    lines = _run(installed, "detect", str(stepped), "--detector", "example-jump", "--train", "300", "--pfa", "1e-5",
                 "--json-lines")
    assert lines.returncode == 1, lines.stderr
    alarms = [json.loads(line)["t_ns"] for line in lines.stdout.splitlines() if json.loads(line)["state"] == "alarm"]
    assert alarms[0] == 800_000_000_000
    clean = _run(installed, "detect", str(_clock_bias_csv(tmp_path / "clean.csv", None)), "--detector",
                 "example-jump", "--train", "300", "--pfa", "1e-5", "--json")
    assert clean.returncode == 0, clean.stderr
    refused = _run(installed, "detect", str(stepped), "--detector", "example-jump", "--train", "300", "--window", "5")
    assert refused.returncode == 2 and "has no window" in refused.stderr


def _dist_info(folder: Path, name: str, group: str, points: dict[str, str]) -> None:
    dist = folder / f"{name}-0.1.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()))


def test_a_plugin_that_fails_to_load_is_named_and_one_that_takes_a_builtin_name_is_refused(tmp_path, monkeypatch):
    _dist_info(tmp_path, "broken_plugin", "chronofuse.servos", {"broken": "no_such_module:ENTRY", "kalman": "x:Y"})
    monkeypatch.syspath_prepend(str(tmp_path))
    SERVOS.refresh()
    try:
        with pytest.warns(UserWarning, match="'kalman'.*names a built-in servos member; the built-in is kept"):
            names = SERVOS.names()
        assert "broken" in names and names.count("kalman") == 1
        with pytest.raises(PluginError, match="'broken' \\(no_such_module:ENTRY of distribution broken_plugin 0.1\\)"):
            SERVOS.create("broken")
        assert type(SERVOS.create("kalman", context={"h": None})).__name__ == "KalmanServo"
    finally:
        monkeypatch.undo()
        SERVOS.refresh()
