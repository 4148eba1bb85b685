"""The table of injected faults on the real Trimble stations (:mod:`chronofuse.experiments.integrity_real`)."""

from __future__ import annotations

import csv
from pathlib import Path


def _yes(value: bool) -> str:
    return "yes" if value else "no"


def write_trimble_table(rows: list[dict], out_dir: Path) -> Path:
    """Write ``trimble_injections.csv`` (every row) and ``trimble_injections.md`` (summary and rows) in ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / "trimble_injections.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Identification on the real Trimble 5700 stations with injected faults",
        "",
        "Written by `python -m chronofuse.experiments.integrity_real` (module docstring: stations, fault sizes,",
        "detector). Onset 1800 s (epoch 60 of 120), fault to the end of the record; window 10, P_fa 1e-3,",
        "each channel trained on its first 40 epochs.",
        "",
        "| station | code | fault | cases | named alone | named before onset | latched to end | median delay (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault((row["station"], row["code"], row["fault"]), []).append(row)
    for (station, code, fault), group in groups.items():
        delays = sorted(r["delay_s"] for r in group if r["delay_s"] is not None)
        median = f"{delays[len(delays) // 2]:g}" if delays else "-"
        lines.append(f"| {station} | {code} | {fault} | {len(group)} | {sum(r['alone'] for r in group)} | "
                     f"{sum(r['before_onset'] for r in group)} | {sum(r['latched_to_end'] for r in group)} | {median} |")
    lines += ["", "Every case:", "", "| station | code | fault | satellite | named | alone | delay (s) | before onset | latched |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        delay = "-" if r["delay_s"] is None else f"{r['delay_s']:g}"
        lines.append(f"| {r['station']} | {r['code']} | {r['fault']} | {r['satellite']} | {r['named']} | "
                     f"{_yes(r['alone'])} | {delay} | {_yes(r['before_onset'])} | {_yes(r['latched_to_end'])} |")
    path = out_dir / "trimble_injections.md"
    path.write_text("\n".join(lines) + "\n")
    return path
