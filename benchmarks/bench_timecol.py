"""Records with a time column: the reader and the ``chronofuse stability`` command against pandas' read.

A seeded two-column file (UNIX seconds at 100 Hz written by pyarrow's shortest round-trip text, then the
phase; 370 MB at 1e7 points) is written to a temporary directory; in the same run:

- ``pandas.read_csv`` of that file in this process (the baseline: reading alone, both columns as float64);
- ``chronofuse.io.records.read_record(FILE)`` in a child process (time tags to exact integer ns, the grid,
  the jitter): wall time from the call to its return (the modules imported and numba's cached kernels
  loaded by a read of a 300-line file first, as pandas is imported in the baseline's process and as the
  CLI's warm-up thread loads them), and the child's peak resident memory (``VmHWM``);
- ``chronofuse stability FILE --dev oadev,mtie --taus octave --json`` as the console script runs it
  (``benchmarks/bench_cli.py``'s child), wall time and peak memory.

Targets at 1e7: the reader within 3x pandas' read and under 1 GiB; the command's ratio is reported.
``--points 1e8`` measures one size (a 3.8 GB file): the command must stay under 8 GB.

Run alone: ``.venv/bin/python benchmarks/bench_timecol.py [--quick] [--points N]``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pcsv

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _timing import print_rows  # noqa: E402
from bench_cli import CHILD, run_child  # noqa: E402  (the console-script child and its peak memory)

SEED = 20240612
MAX_READ_RATIO = 3.0
MAX_READ_MIB = 1024.0
MAX_CLI_MIB_1E8 = 8000.0

READER = (
    "import sys, time, tempfile, os\n"
    "from chronofuse.io.records import read_record\n"
    "warm = os.path.join(tempfile.mkdtemp(), 'warm.csv')\n"  # numba's cached kernels loaded, as the CLI's warm-up does
    "open(warm, 'w').write(''.join(f'{1.7e9 + k / 100},{k * 1e-12}\\n' for k in range(300)))\n"
    "read_record(warm)\n"
    "start = time.perf_counter()\n"
    "rec = read_record(sys.argv[1])\n"
    "sys.stderr.write(f'READ_S {time.perf_counter() - start}\\n')\n"
    "line = next(s for s in open('/proc/self/status') if s.startswith('VmHWM:'))\n"
    "sys.stderr.write(f'PEAK_KB {line.split()[1]}\\n')\n"
    "assert rec.rate_hz == 100.0 and rec.values.size == int(sys.argv[2]), (rec.rate_hz, rec.values.size)\n"
)


def write_time_file(path: Path, n_points: int, seed: int = SEED) -> None:
    """UNIX seconds at 100 Hz and phase (s), comma separated, written in blocks of 1e7 rows."""
    rng = np.random.default_rng(seed)
    with pa.OSFile(str(path), "wb") as sink:
        writer = None
        for start in range(0, n_points, 10_000_000):
            n = min(10_000_000, n_points - start)
            x = np.cumsum(rng.standard_normal(n)) * 1e-12 + rng.standard_normal(n) * 1e-10
            table = pa.table({"t": 1.7e9 + (start + np.arange(n)) / 100.0, "x": x})
            if writer is None:
                writer = pcsv.CSVWriter(sink, table.schema, write_options=pcsv.WriteOptions(include_header=False))
            writer.write_table(table)
        writer.close()


def _stderr_value(err: str, key: str) -> float:
    return float(next(line.split()[1] for line in err.splitlines() if line.startswith(key)))


def measure(n_points: int, workdir: Path, repeats: int, with_cli: bool = True) -> dict:
    path = workdir / f"timecol_{n_points:.0e}.csv"
    write_time_file(path, n_points)
    reads, readers, clis = [], [], []
    for _ in range(repeats):
        start = time.perf_counter()
        frame = pd.read_csv(path, header=None)
        reads.append(time.perf_counter() - start)
        assert frame.shape == (n_points, 2)
        del frame
        _, peak, code, err = run_child([sys.executable, "-c", READER, str(path), str(n_points)])
        if code != 0:
            raise RuntimeError(f"read_record failed on {path}: {err[-800:]}")
        readers.append((_stderr_value(err, "READ_S"), peak))
        if with_cli:
            wall, peak, code, err = run_child([sys.executable, "-c", CHILD, "stability", str(path), "--dev", "oadev,mtie",
                                               "--taus", "octave", "--json"])
            if code != 0:
                raise RuntimeError(f"the CLI exited with {code} on {path}: {err[-800:]}")
            clis.append((wall, peak))
    out = {"n": n_points, "read_s": min(reads), "reader_s": min(r[0] for r in readers),
           "reader_mib": max(r[1] for r in readers), "size_mb": path.stat().st_size / 1e6, "repeats": repeats}
    if clis:
        out.update(cli_s=min(c[0] for c in clis), cli_mib=max(c[1] for c in clis))
    return out


def _row(name, ours_s, baseline, baseline_s, target, passed, note):
    return {"name": name, "ours_s": float(ours_s), "baseline": baseline,
            "baseline_s": None if baseline_s is None else float(baseline_s),
            "ratio": None if baseline_s is None else float(baseline_s) / float(ours_s), "target": target,
            "passed": bool(passed), "note": note}


def rows_for(m: dict, cli_target: str, cli_ok) -> list[dict]:
    n = f"{m['n']:.0e}"
    rows = [
        _row(f"read_record time column N={n} (child, wall)", m["reader_s"], "pandas.read_csv, same file", m["read_s"],
             f"<= {MAX_READ_RATIO:g}x read_csv", m["reader_s"] <= MAX_READ_RATIO * m["read_s"],
             f"{m['reader_s'] / m['read_s']:.2f}x pandas' read of the {m['size_mb']:.0f} MB file (best of "
             f"{m['repeats']}); exact integer-ns tags, grid and jitter"),
        _row(f"read_record time column peak N={n} (MiB, not s)", m["reader_mib"], None, None,
             f"< {MAX_READ_MIB:g} MiB" if m["n"] <= 10_000_000 else "informational",
             m["reader_mib"] < MAX_READ_MIB or m["n"] > 10_000_000, "VmHWM of the reading child, imports included"),
    ]
    if "cli_s" in m:
        rows += [
            _row(f"cli stability oadev+mtie time column N={n} (wall)", m["cli_s"], "pandas.read_csv, same file",
                 m["read_s"], "reported", True, f"{m['cli_s'] / m['read_s']:.1f}x pandas' read"),
            _row(f"cli time column peak N={n} (MiB, not s)", m["cli_mib"], None, None, cli_target, cli_ok(m["cli_mib"]),
                 "VmHWM of the CLI subprocess"),
        ]
    return rows


def run(quick: bool = False) -> list[dict]:
    n_points = 1_000_000 if quick else 10_000_000
    with tempfile.TemporaryDirectory() as tmp:
        m = measure(n_points, Path(tmp), repeats=2 if quick else 3)
    return rows_for(m, "< 1536 MiB", lambda mib: mib < 1536)


def _measure_one(argv: list[str]) -> None:
    n_points = int(float(argv[argv.index("--points") + 1]))
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 1
    with tempfile.TemporaryDirectory(dir=argv[argv.index("--dir") + 1] if "--dir" in argv else None) as tmp:
        m = measure(n_points, Path(tmp), repeats=repeats)
    for r in rows_for(m, f"< {MAX_CLI_MIB_1E8:g} MiB", lambda mib: mib < MAX_CLI_MIB_1E8):
        print(r, flush=True)


if __name__ == "__main__":
    if "--points" in sys.argv[1:]:
        _measure_one(sys.argv[1:])
        sys.exit(0)
    print_rows(run(quick="--quick" in sys.argv[1:]), name_width=52)
