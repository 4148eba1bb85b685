"""The live table: one row per receiver, redrawn in place (rich ``Live``: no flicker, no scrolling)."""

from __future__ import annotations

import math

from rich.table import Table

__all__ = ["receiver_table"]

_MODES = {0: "-", 1: "none", 2: "2D", 3: "3D"}


def _num(value, scale: float = 1.0, fmt: str = "{:.2f}") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return fmt.format(value * scale)


def receiver_table(monitor) -> Table:
    """A rich table of ``monitor``'s receivers (a :class:`chronofuse.monitor.engine.Monitor`)."""
    table = Table(title=f"chronofuse monitor: {len(monitor.receivers)} receiver(s), "
                        f"{monitor.acknowledged:,} epochs logged", expand=False)
    for col in ("receiver", "link", "fix", "sats", "GDOP", "usable", "UTC", "leap", "bias (ns)", "drift (ns/s)",
                "qErr (ns)", "alarms", "flags", "outages"):
        table.add_column(col, justify="right" if col not in ("receiver", "UTC", "flags") else "left")
    for rx in monitor.receivers.values():
        r = rx.last or {}
        flags = []
        if r.get("alarm") or r.get("state") == "alarm":
            flags.append("[red]ALARM[/red]")
        if r.get("dissent"):
            flags.append("[yellow]UTC/leap dissent[/yellow]")
        if r.get("jump"):
            flags.append("[yellow]offset jump[/yellow]")
        usable = r.get("usable")
        table.add_row(
            rx.name,
            "[green]up[/green]" if rx.connected else "[red]down[/red]",
            _MODES.get(r.get("fix_mode", 0), "?"),
            str(r["n_sats"]) if r.get("n_sats", -1) >= 0 else "-",
            _num(r.get("gdop")),
            "-" if usable is None else ("[green]yes[/green]" if usable else "[red]no[/red]"),
            r.get("utc", "-"),
            str(r.get("leap_s", "-")) + ("+" if r.get("leap_pending", 0) > 0 else "-" if r.get("leap_pending", 0) < 0 else ""),
            _num(r.get("clock_bias_s"), 1e9, "{:.1f}"),
            _num(r.get("clock_drift_s_per_s"), 1e9, "{:.3f}"),
            _num(r.get("qerr_s"), 1e9, "{:.2f}"),
            str(rx.alarms),
            " ".join(flags),
            str(rx.outages),
        )
    return table
