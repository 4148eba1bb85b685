"""The public surface: everything in chronofuse.api.__all__ exists and is what its module defines."""

import os
import subprocess
import sys

import chronofuse.api as api


def test_every_public_name_is_importable_from_the_api():
    missing = [name for name in api.__all__ if not hasattr(api, name)]
    assert not missing


def test_importing_the_api_loads_no_part_of_the_toolkit_until_a_name_is_used():
    script = ("import sys; import chronofuse.api as api; before = sorted(m for m in sys.modules if m.startswith("
              "('numpy', 'scipy', 'chronofuse.')) and m != 'chronofuse.api'); api.adev; "
              "print(before, 'chronofuse.analysis.stability' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["[]", "True"], done.stdout + done.stderr


def test_every_public_name_is_listed_by_dir_and_an_unknown_one_is_an_attribute_error():
    assert set(api.__all__) <= set(dir(api))
    try:
        api.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:
        raise AssertionError("an unknown name resolved")


def test_python_dash_m_chronofuse_runs_the_program():
    from chronofuse import __version__

    done = subprocess.run([sys.executable, "-m", "chronofuse", "--version"], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == __version__ and done.stderr == ""
    usage = subprocess.run([sys.executable, "-m", "chronofuse", "detect"], capture_output=True, text=True)
    assert usage.returncode == 2 and usage.stderr == "chronofuse detect: error: Missing argument 'file'.\n"


def test_the_api_reexports_rather_than_redefines():
    for name in api.__all__:
        obj = getattr(api, name)
        module = getattr(obj, "__module__", None)
        if module is not None:
            assert module.startswith("chronofuse.") and module != "chronofuse.api", name


def test_importing_the_api_and_drawing_a_figure_leave_the_users_matplotlib_backend_alone(tmp_path):
    # A fresh interpreter with a non-Agg backend chosen by the user (svg: always available, no screen).
    script = f"""
import sys
import matplotlib
import numpy as np
import chronofuse.api as api
from chronofuse.report.figures import plot_deviations

after_import = matplotlib.get_backend()
x = np.cumsum(np.random.default_rng(1).standard_normal(1000)) * 1e-9
plot_deviations({{"adev": api.adev(x, 1.0, np.array([1.0, 10.0]))}}, {str(tmp_path / "a.png")!r})
print(after_import, matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
"""
    env = {**os.environ, "MPLBACKEND": "svg"}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["svg", "svg", "False"], done.stderr
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_importing_the_report_modules_and_drawing_leave_the_users_matplotlib_backend_alone(tmp_path):
    # integrity, swarm and gnssdo reports once called matplotlib.use("Agg") at import; the user's choice must stay.
    script = f"""
import sys
import matplotlib
import pandas as pd
import chronofuse.report.integrity
import chronofuse.report.gnssdo
from chronofuse.report.swarm import plot_sweep

after_import = matplotlib.get_backend()
summary = pd.DataFrame({{"algorithm": ["a", "a"], "value": [1.0, 2.0], "rmse_ns": [3.0, 4.0],
                         "pcrb_rms_ns": [1.0, 1.5]}})
plot_sweep(summary, "rate", "Hz", {str(tmp_path / "s.png")!r})
print(after_import, matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
"""
    env = {**os.environ, "MPLBACKEND": "svg"}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["svg", "svg", "False"], done.stderr
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
