"""Progress of a long command, as the console script shows it: on a terminal (a real pseudo-terminal) a bar
with the percentage and the ETA; through a pipe plain lines on stderr with the same, stdout untouched;
``--quiet`` nothing at all; and a command shorter than the plain lines' first interval prints none.

``CHRONOFUSE_PROGRESS_S`` shortens the plain lines' interval (5 s by default) so a run of a few seconds shows them.
"""

from __future__ import annotations

import os
import re
import select
import subprocess
import sys
from pathlib import Path

from conftest import real_data_dir

SRC = Path(__file__).resolve().parents[2] / "src"
CODE = "import sys; from chronofuse.cli.main import main; sys.argv[0] = 'chronofuse'; main()"
SWARM = ["swarm", "run", "--algorithm", "ptp-mls,rtt-rvc", "--trials", "2", "--seed", "1"]
PLAIN = re.compile(r"^swarm run: (?P<what>.+?), (?P<pct>\d+) % \((?P<gone>[^,)]+) gone(, ETA (?P<eta>[^)]+))?\)$")


def _env(**extra) -> dict:
    path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return {**os.environ, "PYTHONPATH": path, "COLUMNS": "100", **extra}


def _piped(args: list[str], **env) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", CODE, *args], capture_output=True, text=True, env=_env(**env),
                          timeout=300)


def test_off_a_terminal_progress_is_plain_lines_on_stderr_with_percent_and_eta(tmp_path):
    done = _piped(SWARM, CHRONOFUSE_PROGRESS_S="0.05")
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    matched = [PLAIN.match(line) for line in lines]
    assert lines and all(matched), lines  # nothing else on stderr
    pct = [int(m["pct"]) for m in matched]
    assert pct == sorted(pct) and 0 < pct[-1] < 100  # never backwards; the last stage starts short of 100 %
    assert {m["what"] for m in matched} <= {"simulating 2 links", "ptp-mls", "rtt-rvc"}
    assert all(m["eta"] for m in matched if int(m["pct"]) > 0)  # an ETA once anything is done
    assert "swarm run:" not in done.stdout and "ETA" not in done.stdout and "RMSE" in done.stdout


def test_quiet_silences_the_progress_lines():
    done = _piped([*SWARM, "--quiet"], CHRONOFUSE_PROGRESS_S="0.05")
    assert done.returncode == 0 and done.stdout == "" and done.stderr == ""


def test_a_command_shorter_than_the_first_interval_prints_no_progress():
    phase = real_data_dir() / "stability" / "phasedat" / "PHASE.DAT"
    done = _piped(["stability", str(phase), "--rate", "1", "--dev", "adev"], CHRONOFUSE_PROGRESS_S="60")
    assert done.returncode == 0 and done.stderr == ""


def test_on_a_terminal_progress_is_a_bar_with_percent_and_eta():
    master, slave = os.openpty()
    proc = subprocess.Popen([sys.executable, "-c", CODE, *SWARM], stdin=slave, stdout=slave, stderr=slave,
                            env=_env(TERM="xterm-256color"), close_fds=True)
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 120)
        if not ready:
            proc.kill()
            raise AssertionError("no output for 120 s")
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    assert proc.wait(timeout=60) == 0
    os.close(master)
    screen = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", b"".join(chunks).decode("utf-8", "replace"))
    assert re.search(r"swarm run: (ptp-mls|rtt-rvc).*\b\d{1,3}%.*ETA", screen), screen[-2000:]
    assert re.search(r"ETA\s+(\d+:\d\d:\d\d|-:--:--)", screen)
    assert "RMSE" in screen  # the table follows the bar


def test_the_eta_does_not_grow_while_a_long_stage_reports_no_fraction():
    import pytest

    from chronofuse.cli.common import _eta

    # 10 % reached at 2 s: 18 s left by that rate; 5 s later, 13 s; once the stage has outlasted the rate
    # (20 s and more after the start with still 10 %), no ETA rather than one that grows with the wait
    assert _eta(2.0, 0.1, 2.0) == pytest.approx(18.0)
    assert _eta(7.0, 0.1, 2.0) == pytest.approx(13.0)
    assert _eta(25.0, 0.1, 2.0) is None
    assert _eta(3.0, None) is None and _eta(3.0, 0.0) is None
    assert _eta(9.0, 1.0, 9.0) == 0.0
