"""Writing a record as a Stable32 data file, for the field's own analysis program.

Stable32 (W. J. Riley, Hamilton Technical Services) reads phase or fractional-frequency data as text, one
value per line, after ``#`` comment lines (the layout of the GPS 1PPS record in ``tests/data/stability/gps``,
which Stable32 1.53 read for the published tables shipped beside it). It takes the sampling interval (tau0)
and the data type from its dialog, so the header says them for the person who opens the file. Stable32
marks a gap with the value 0 (the convention :func:`chronofuse.io.records.read_record` honours with
``zero_is_gap=True``): a gap (NaN) is written as 0, and a record that holds an exact 0 as a measurement
(a ts2phc offset of 0 ns) is written with a warning, since Stable32 will take those samples for gaps.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from chronofuse.validation import check_choice

__all__ = ["write_stable32"]


def write_stable32(path: str | Path, values: np.ndarray, rate_hz: float, kind: str, source: str = "") -> int:
    """Write ``values`` (phase in s, or fractional frequency; shape (N,), NaN gaps) as a Stable32 data file.

    Returns the number of zeros written for gaps. Values are written with 12 significant digits (a phase of
    1 s keeps picoseconds; Stable32 itself prints 5).
    """
    check_choice(kind, "kind", ("phase", "freq"))
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 1 or values.size == 0:
        raise ValueError(f"values has shape {values.shape}, must be (N,) with N >= 1")
    gaps = np.isnan(values)
    zeros = int((values == 0.0).sum())
    if zeros:
        warnings.warn(f"{path}: {zeros} samples are exactly 0, which Stable32 reads as gaps (add a constant "
                      "phase offset before exporting to keep them)", stacklevel=2)
    header = [f"# chronofuse export for Stable32: {'phase data (s)' if kind == 'phase' else 'frequency data'}",
              f"# tau0 = {1.0 / rate_hz:.12g} s, {values.size} points, {int(gaps.sum())} gaps written as 0"]
    if source:
        header.append(f"# from {source}")
    body = np.where(gaps, 0.0, values)
    with open(path, "w", encoding="ascii") as fh:
        fh.write("\n".join(header) + "\n")
        fh.write("\n".join(f"{v:.12g}" for v in body.tolist()) + "\n")
    return int(gaps.sum())
