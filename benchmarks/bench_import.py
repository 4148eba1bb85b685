"""``import chronofuse.api``, ``chronofuse --help`` and ``chronofuse detect --help``, each in a fresh interpreter,
against ``import numpy, scipy`` in another.

Both run as ``python -c ...`` subprocesses, alternating, so the machine's load falls on both alike; the
best of ``repeats`` runs of each is kept (the run least disturbed). Target: the API's import costs at most
1.5x the numerical stack's (ratio = baseline_s / ours_s >= 1/1.5), and so do the two help screens (the program
lists its subcommands without importing their modules; ``detect`` imports the library inside the command).
Measured on this branch, 2 shared cores (``--repeats 5``): ``chronofuse --help`` went from 7.8-9.0 s (every
subcommand's module, the whole toolkit, imported to list them) to about 0.5 s. The API is lazy (each name loads its
module on first use), so its import is the interpreter's start plus one small module; the note also gives
an interpreter that imports nothing (``python -c pass``) and one that loads every name of the API.

Run alone: ``.venv/bin/python benchmarks/bench_import.py [--quick] [--repeats R]``.
"""

from __future__ import annotations

import subprocess
import sys
import time

MAX_SLOWDOWN = 1.5
OURS = "import chronofuse.api"
BASELINE = "import numpy, scipy"
NOTHING = "pass"
EVERYTHING = "import chronofuse.api as a; [getattr(a, n) for n in a.__all__]"
#: The help screens timed (``python -m chronofuse ...``), as a user's shell starts them.
HELP = {"chronofuse --help": ("--help",), "chronofuse detect --help": ("detect", "--help")}
#: The floor of any help screen: a Typer program of two commands, one option, printing its help.
FLOOR = ("import sys, typer; app = typer.Typer(); app.command()(lambda rate: None); app.command('b')(lambda: None); "
         "sys.argv = ['x', '--help']; app()")


def _wall_s(code: str | tuple) -> float:
    argv = ["-m", "chronofuse", *code] if isinstance(code, tuple) else ["-c", code]
    start = time.perf_counter()
    subprocess.run([sys.executable, *argv], check=code is not FLOOR, capture_output=True)
    return time.perf_counter() - start


def measure(repeats: int) -> dict:
    """Best wall time (s) of each snippet (or help screen) over ``repeats`` alternating runs."""
    best = {code: float("inf") for code in (OURS, BASELINE, NOTHING, EVERYTHING, FLOOR, *HELP.values())}
    for _ in range(repeats):
        for code in best:
            best[code] = min(best[code], _wall_s(code))
    return best


def run(quick: bool = False, repeats: int | None = None) -> list[dict]:
    best = measure(repeats or (3 if quick else 10))
    ours, base = best[OURS], best[BASELINE]
    note = (f"python -c pass {best[NOTHING]:.3f} s; every API name loaded {best[EVERYTHING]:.3f} s; "
            f"best of {repeats or (3 if quick else 10)} alternating runs")
    return [{"name": "import chronofuse.api", "ours_s": ours, "baseline": "import numpy, scipy", "baseline_s": base,
             "ratio": base / ours, "target": f"<= {MAX_SLOWDOWN:g}x numpy+scipy", "passed": ours <= MAX_SLOWDOWN * base,
             "note": note}] + [
        {"name": name, "ours_s": best[argv], "baseline": "import numpy, scipy", "baseline_s": base,
         "ratio": base / best[argv], "target": f"<= {MAX_SLOWDOWN:g}x numpy+scipy",
         "passed": best[argv] <= MAX_SLOWDOWN * base,
         "note": f"a bare Typer program's --help {best[FLOOR]:.3f} s (the floor); best of {repeats or (3 if quick else 10)} "
                 "alternating runs"}
        for name, argv in HELP.items()]


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=None)
    args = parser.parse_args()
    for row in run(args.quick, args.repeats):
        print(f"{row['name']}: {row['ours_s']:.3f} s, {row['baseline']} {row['baseline_s']:.3f} s, "
              f"{row['ours_s'] / row['baseline_s']:.2f}x ({row['target']}: {'ok' if row['passed'] else 'FAIL'}); "
              f"{row['note']}")
