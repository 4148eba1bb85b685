"""Stable32's result tables: the published reference values the stability engine is checked against.

Stable32 (W. J. Riley, Hamilton Technical Services) writes a run of one statistic as a text table after
``#`` header lines (file, data points, sigma type, confidence factor), one row per averaging factor:

* seven columns ``AF Tau # Alpha MinSigma Sigma MaxSigma`` for the deviations (with their confidence
  interval and the noise type alpha it identified), or
* four columns ``AF Tau # Value`` for MTIE and TIE rms.

Stable32 also marks rows it does not trust by commenting them out with ``#``: those are skipped here too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.validation import InputDataError

#: Column counts of the two table layouts.
WIDTHS = (4, 7)


def read_stable32_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read a Stable32 result table.

    Returns arrays of shape (k,), one entry per row: ``af`` (averaging factor, int), ``tau`` (s), ``n``
    (the number of terms, int) and ``dev`` (the Sigma or Value column); seven-column tables add ``alpha``
    (int), ``lo`` and ``hi`` (the Min Sigma and Max Sigma columns).

    Raises :class:`InputDataError` naming the file (and line) for a table with no rows, a ragged row, a
    row that is not numbers, or a layout of other than 4 or 7 columns.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    numbered = [(k, line.split()) for k, line in enumerate(lines, start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise InputDataError("no table rows (only comments)", str(path))
    width = len(numbered[0][1])
    if width not in WIDTHS:
        raise InputDataError(f"{width} columns, must be 4 (AF Tau # Value) or 7 (AF Tau # Alpha Min Sigma Max)",
                             str(path), numbered[0][0])
    rows = np.empty((len(numbered), width))
    for i, (lineno, tokens) in enumerate(numbered):
        if len(tokens) != width:
            raise InputDataError(f"{len(tokens)} columns on this row, expected {width}", str(path), lineno)
        try:
            rows[i] = [float(t) for t in tokens]
        except ValueError:
            raise InputDataError(f"cannot read row {' '.join(tokens)!r} as numbers", str(path), lineno) from None
    out = {"af": rows[:, 0].astype(np.int64), "tau": rows[:, 1], "n": rows[:, 2].astype(np.int64)}
    if width == 7:
        out.update(alpha=rows[:, 3].astype(np.int64), lo=rows[:, 4], dev=rows[:, 5], hi=rows[:, 6])
    else:
        out["dev"] = rows[:, 3]
    return out
