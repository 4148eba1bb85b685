"""The ``chronofuse stability`` command on a large phase file, as a user runs it, against pandas' reader.

A seeded 1e7-point phase file (one column, shortest round-trip decimal text, 233 MB) is written to a
temporary directory; then, in the same run:

- ``pandas.read_csv`` of that file is timed in this process (the baseline: reading alone);
- ``chronofuse stability FILE --rate 1 --dev oadev,mtie --taus octave --json`` runs in a subprocess as the
  ``chronofuse`` console script runs it (``chronofuse.cli.main:main``, which loads only the subcommand it
  runs), behind a line that times the start-up: importing ``chronofuse.cli.main`` and the stability
  subcommand with what it imports; its wall time and peak resident memory (that child's own ``VmHWM``,
  see :func:`run_child`) are recorded, and the start-up time, so the note can say how much of it is start-up.

Targets: the command within 8x pandas' read time and under 1.5 GiB peak. The same is measured at 1e6
points, and time and memory are extrapolated linearly (``a + b N`` through the two sizes) to 1e8 points
(a day at 1 kHz): an extrapolation, not a measurement. ``quick`` uses 1e5 and 1e6 points.

Run alone: ``.venv/bin/python benchmarks/bench_cli.py [--quick]``; one size, measured rather than
extrapolated: ``.venv/bin/python benchmarks/bench_cli.py --points 1e8 [--repeats R]``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pcsv

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import print_rows  # noqa: E402

SEED = 20240611
HERE = Path(__file__).resolve().parent
MAX_RATIO = 8.0
MAX_PEAK_MIB = 1536.0


def write_phase_file(path: Path, n_points: int, seed: int = SEED) -> None:
    """Seeded phase (s), random-walk FM integrated plus white PM, one value per line."""
    rng = np.random.default_rng(seed)
    y = np.cumsum(rng.standard_normal(n_points)) * 1e-14 + rng.standard_normal(n_points) * 1e-11
    x = np.cumsum(y) + rng.standard_normal(n_points) * 1e-10
    pcsv.write_csv(pa.table({"x": x}), path, write_options=pcsv.WriteOptions(include_header=False))


# The child: the CLI as the ``chronofuse`` console script runs it (``main``, which loads only the subcommand
# it runs and freezes the heap on the way out), with its start-up (importing the program and that
# subcommand, imported first here so that the time can be told) written to stderr.
CHILD = (
    "import atexit, sys, time\n"
    "start = time.perf_counter()\n"
    "def _peak():\n"  # VmHWM: this process's own peak, not the parent's pages counted before exec
    "    try:\n"
    "        line = next(s for s in open('/proc/self/status') if s.startswith('VmHWM:'))\n"
    "        sys.stderr.write(f'PEAK_KB {line.split()[1]}\\n')\n"
    "    except OSError:\n"
    "        pass\n"
    "atexit.register(_peak)\n"
    "import importlib\n"
    "from chronofuse.cli.main import _wanted, main\n"
    "sys.argv = ['chronofuse', *sys.argv[1:]]\n"
    "for name in _wanted(sys.argv[1:]) or ():  # the subcommand's modules, which main() would import\n"
    "    importlib.import_module(f'chronofuse.cli.{name}')\n"
    "sys.stderr.write(f'IMPORT_S {time.perf_counter() - start}\\n')\n"
    "main()\n"
)


def run_child(args: list[str]) -> tuple[float, float, int, str]:
    """Run ``args``; return (wall s, peak RSS MiB of that child, exit code, its stderr).

    The peak is the child's own ``VmHWM`` (written by :data:`CHILD` at exit) where Linux gives it: the
    ``ru_maxrss`` of a child started by (v)fork + exec also counts the parent's resident pages before the
    exec (the 1e8 run reported 3.6 GiB that way, the parent's size; ``/usr/bin/time`` gave 2.5 GiB).
    """
    env = dict(os.environ, PYTHONPATH=str(HERE.parent / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    start = time.perf_counter()
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    err = proc.stderr.read().decode(errors="replace")
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    peak_kb = next((float(line.split()[1]) for line in err.splitlines() if line.startswith("PEAK_KB")), usage.ru_maxrss)
    return wall, peak_kb / 1024.0, os.waitstatus_to_exitcode(status), err


def measure(n_points: int, workdir: Path, repeats: int = 3) -> dict:
    """Best of ``repeats`` for pandas' read and for the CLI alike (the machine is shared: the minimum is
    the run least disturbed by other work, for both sides of the ratio), peak memory the largest seen."""
    path = workdir / f"phase_{n_points:.0e}.txt"
    write_phase_file(path, n_points)
    cli = [sys.executable, "-c", CHILD, "stability", str(path), "--rate", "1", "--dev", "oadev,mtie", "--taus",
           "octave", "--json"]
    reads, runs = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        frame = pd.read_csv(path, header=None)
        reads.append(time.perf_counter() - start)
        assert frame.shape == (n_points, 1)
        del frame
        wall_s, peak_mib, code, err = run_child(cli)
        if code != 0:
            raise RuntimeError(f"the CLI exited with {code} on {path}: {err[-500:]}")
        startup_s = float(next(line.split()[1] for line in err.splitlines() if line.startswith("IMPORT_S")))
        runs.append((wall_s, startup_s, peak_mib))
    wall_s, startup_s, _ = min(runs)
    return {"n": n_points, "read_s": min(reads), "startup_s": startup_s, "cli_s": wall_s,
            "peak_mib": max(r[2] for r in runs), "size_mb": path.stat().st_size / 1e6, "repeats": repeats}


def _row(name, ours_s, baseline, baseline_s, target, passed, note):
    return {"name": name, "ours_s": float(ours_s), "baseline": baseline,
            "baseline_s": None if baseline_s is None else float(baseline_s),
            "ratio": None if baseline_s is None else float(baseline_s) / float(ours_s), "target": target,
            "passed": bool(passed), "note": note}


def run(quick: bool = False) -> list[dict]:
    small, big = (100_000, 1_000_000) if quick else (1_000_000, 10_000_000)
    with tempfile.TemporaryDirectory() as tmp:
        low = measure(small, Path(tmp))
        high = measure(big, Path(tmp))
    rows = []
    for m in (low, high):
        is_target = m is high  # the smaller size is the scaling point: its time is mostly start-up
        rows.append(_row(
            f"cli stability oadev+mtie octave N={m['n']:.0e} (wall)", m["cli_s"], "pandas.read_csv, same file",
            m["read_s"], f"<= {MAX_RATIO:g}x read_csv" if is_target else "scaling point",
            m["cli_s"] <= MAX_RATIO * m["read_s"] or not is_target,
            f"{m['cli_s'] / m['read_s']:.1f}x pandas' read ({m['size_mb']:.0f} MB file; best of {m['repeats']} "
            f"runs each), of which start-up "
            f"(importing the program and the stability subcommand) {m['startup_s']:.1f} s; without it "
            f"{(m['cli_s'] - m['startup_s']) / m['read_s']:.1f}x"))
        rows.append(_row(
            f"cli peak RSS N={m['n']:.0e} (MiB, not s)", m["peak_mib"], None, None, f"< {MAX_PEAK_MIB:g} MiB",
            m["peak_mib"] < MAX_PEAK_MIB, "peak resident memory (VmHWM) of the CLI subprocess, imports included"))
    work = {m["n"]: m["cli_s"] - m["startup_s"] for m in (low, high)}  # start-up is fixed, not per point
    slope_t = (work[high["n"]] - work[low["n"]]) / (high["n"] - low["n"])
    slope_m = (high["peak_mib"] - low["peak_mib"]) / (high["n"] - low["n"])
    n8 = 100_000_000
    t8 = high["cli_s"] + slope_t * (n8 - high["n"])  # same start-up as at 1e7
    m8 = high["peak_mib"] + slope_m * (n8 - high["n"])
    rows.append(_row(
        "cli N=1e8 extrapolated (wall s)", t8, None, None, "informational", True,
        f"linear through N={low['n']:.0e} and {high['n']:.0e} (start-up excluded from the slope): "
        f"{slope_t * 1e9:.0f} s per 1e9 points; "
        f"peak {m8 / 1024:.1f} GiB ({slope_m * 1e6:.0f} MiB per 1e6 points); not measured"))
    return rows


def _measure_one(argv: list[str]) -> None:
    """``--points N [--repeats R]``: one size measured, not extrapolated (1e8 points: a 2.2 GB file and
    about 2.5 GiB for the command; the README's 1e8 figures come from this)."""
    n_points = int(float(argv[argv.index("--points") + 1]))
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 1
    with tempfile.TemporaryDirectory() as tmp:
        m = measure(n_points, Path(tmp), repeats=repeats)
    print(f"N={m['n']:.0e}: chronofuse stability {m['cli_s']:.2f} s (start-up {m['startup_s']:.2f} s), "
          f"pandas.read_csv {m['read_s']:.2f} s ({m['cli_s'] / m['read_s']:.1f}x), peak {m['peak_mib']:.0f} MiB, "
          f"{m['size_mb']:.0f} MB file, best of {m['repeats']}", flush=True)


if __name__ == "__main__":
    if "--points" in sys.argv[1:]:
        _measure_one(sys.argv[1:])
        sys.exit(0)
    print_rows(run(quick="--quick" in sys.argv[1:]), name_width=48)
