"""A real receiver's 1PPS phase record against a reference clock: the truth a disciplined oscillator is
run against (``chronofuse gnssdo --reference``). One value column (or time and value), 1 Hz, no gaps."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np

from chronofuse.io.records import read_record
from chronofuse.validation import InputError

__all__ = ["read_pps_reference"]


def _data_line(path: Path, index: int) -> int:
    """1-based file line of the ``index``-th data line (0-based) of a text record, for error messages."""
    opener = gzip.open if path.suffix == ".gz" else open
    count = -1
    with opener(path, "rt") as fh:
        for lineno, line in enumerate(fh, start=1):
            text = line.split("#")[0].strip()
            if text and (text[0].isdigit() or text[0] in "+-.n"):
                count += 1
                if count == index:
                    return lineno
    return lineno


def read_pps_reference(path: str | Path, *, min_samples: int = 2) -> np.ndarray:
    """The 1PPS phase (s, shape (N,)) of the record at ``path``, sampled at 1 Hz without gaps.

    Refused, naming the file and line: another rate than 1 Hz (from a time column), any gap, and fewer
    than ``min_samples`` samples.
    """
    path = Path(path)
    try:  # the time column, when there is one, says the rate (a rate given here would override it)
        rec = read_record(path, kind="phase")
    except InputError:
        rec = read_record(path, kind="phase", rate_hz=1.0)
    if not math.isclose(rec.rate_hz, 1.0, rel_tol=1e-6):
        raise InputError(f"the time column gives a rate of {rec.rate_hz:g} Hz; the reference record must be "
                         "sampled at 1 Hz", str(path), _data_line(path, 1))
    if rec.n_gaps:
        first = int(np.flatnonzero(np.isnan(rec.values))[0])
        raise InputError(f"gap in the reference record ({rec.n_gaps} missing samples, the first at sample "
                         f"{first}); the loop needs one sample every second", str(path), _data_line(path, first))
    if rec.values.size < min_samples:
        raise InputError(f"{rec.values.size} samples, need at least {min_samples}", str(path))
    return rec.values
