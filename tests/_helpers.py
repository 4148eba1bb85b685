"""Test helpers shared across the suite (importable as ``_helpers``: tests/ is on pythonpath)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def read_stable32_table(path: Path) -> dict[str, np.ndarray]:
    """Read a Stable32 result table: ``AF Tau # Alpha MinSigma Sigma MaxSigma`` or ``AF Tau # Value``.

    Lines starting with ``#`` are comments (Stable32 marks unreliable rows that way too); returns
    columns ``af, tau, n`` and either ``alpha, lo, dev, hi`` or ``dev``.
    """
    rows = [line.split() for line in Path(path).read_text().splitlines() if line.strip() and not line.lstrip().startswith("#")]
    arr = np.array(rows, dtype=float)
    out = {"af": arr[:, 0].astype(int), "tau": arr[:, 1], "n": arr[:, 2].astype(int)}
    if arr.shape[1] >= 7:
        out.update(alpha=arr[:, 3].astype(int), lo=arr[:, 4], dev=arr[:, 5], hi=arr[:, 6])
    else:
        out["dev"] = arr[:, 3]
    return out


def assert_close_printed(ours, table, rel_digits: int = 5, name: str = ""):
    """Assert equality to the printed precision of a Stable32 table (5 significant digits: rel 1e-4/2 rounding)."""
    ours = np.asarray(ours, dtype=float)
    table = np.asarray(table, dtype=float)
    # A value printed as d.dddde-xx is within half a unit of its last digit.
    tol = 0.5 * 10.0 ** (np.floor(np.log10(np.abs(table))) - (rel_digits - 1))
    bad = np.abs(ours - table) > tol * 1.0001
    assert not bad.any(), f"{name}: ours {ours[bad]} vs table {table[bad]} (tol {tol[bad]})"
