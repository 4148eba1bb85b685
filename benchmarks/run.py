"""Run every benchmark (benchmarks/bench_*.py) and print ratios against baselines timed in the same run.

Usage: ``python benchmarks/run.py [--quick] [--only NAME] [--out out/bench.json]`` (``make bench``).
Each bench module exposes ``run(quick: bool) -> list[dict]`` with keys name, ours_s, baseline,
baseline_s, ratio (baseline_s / ours_s), target, passed, note. Ratios, not absolute times, are what to
compare across machines: this one is noisy and shared.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

HERE = Path(__file__).resolve().parent


def load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes (smoke run)")
    parser.add_argument("--only", default=None, help="run only bench_<ONLY>.py")
    parser.add_argument("--out", default="out/bench.json", help="where to write the rows as JSON")
    args = parser.parse_args(argv)
    console = Console()
    rows = []
    for path in sorted(HERE.glob("bench_*.py")):
        if args.only and path.stem != f"bench_{args.only}":
            continue
        console.print(f"[bold]{path.stem}[/bold] ...")
        start = time.perf_counter()
        for row in load(path).run(quick=args.quick):
            rows.append({"bench": path.stem, **row})
        console.print(f"  done in {time.perf_counter() - start:.1f} s")
    table = Table("bench", "case", "ours (s)", "baseline", "baseline (s)", "ratio", "target", "ok", title="chronofuse benchmarks")
    for r in rows:
        table.add_row(
            r["bench"], r["name"], f"{r['ours_s']:.3f}", r.get("baseline") or "-",
            "-" if r.get("baseline_s") is None else f"{r['baseline_s']:.3f}",
            "-" if r.get("ratio") is None else f"{r['ratio']:.1f}x", r.get("target", ""),
            "[green]yes[/green]" if r.get("passed") else "[red]no[/red]",
        )
    console.print(table)
    for r in rows:
        if r.get("note"):
            console.print(f"- {r['name']}: {r['note']}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": platform.platform(), "python": sys.version.split()[0], "quick": args.quick,
                               "rows": rows}, indent=2))
    console.print(f"rows -> {out}")
    return 0 if all(r.get("passed") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
