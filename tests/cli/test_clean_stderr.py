"""On valid input the program writes nothing to stderr: no leak reports at exit, no dependency warnings.

Each command runs as the console script runs it (``chronofuse.cli.main:main``, in a fresh interpreter), since
what goes wrong here happens at start-up and at exit, which an in-process ``CliRunner`` never reaches.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from _helpers import receivers_dir

from conftest import real_data_dir

RINEX = receivers_dir() / "rinex"
OBS, NAV = RINEX / "rtklib" / "07590920.05o", RINEX / "rtklib" / "07590920.05n"
CLK = RINEX / "gnss_lib_py" / "grg21553.clk.gz"


def _approx_position(path) -> str:
    line = next(s for s in path.read_text().splitlines() if "APPROX POSITION XYZ" in s)
    return ",".join(line.split()[:3])


def _console(*args: str, cwd) -> subprocess.CompletedProcess:
    code = "import sys; from chronofuse.cli.main import main; sys.argv[0] = 'chronofuse'; main()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


CASES = {
    "inspect a RINEX observation file": ["inspect", str(OBS)],
    "inspect a RINEX clock product": ["inspect", str(CLK)],
    "stability of a RINEX clock product's station": ["stability", str(CLK), "--json"],
    "detect in identification mode on a RINEX observation file": [
        "detect", str(OBS), "--nav", str(NAV), "--position", _approx_position(OBS), "--train", "600", "--json"],
    "stability of a text record with a mask and a plot": [
        "stability", str(real_data_dir() / "stability" / "gps" / "gps_1pps_phase_data.txt.gz"), "--rate", "1",
        "--dev", "adev,mtie", "--mask", "prtc-a", "--plot", "p.png"],
}


#: A plain progress line (off a terminal, once a command has run 5 s): asked-for output, not a leak or warning.
PROGRESS = re.compile(r"^[\w ]+: .*\(\d[^()]* gone(, ETA [^()]+)?\)$")


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_valid_command_leaves_stderr_empty(case, tmp_path):
    done = _console(*CASES[case], cwd=tmp_path)
    assert done.returncode in (0, 1, 3), done.stderr  # 1/3: an alarm or integrity unavailable is a verdict
    assert [line for line in done.stderr.splitlines() if not PROGRESS.match(line)] == []
