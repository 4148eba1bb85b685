"""Input validation in one place.

Every check raises an error that names the parameter, its value and what was expected, in the form
``"{name} == {value}, must be {expectation}"`` (the scikit-learn convention).
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np


class ChronofuseError(Exception):
    """Base class of the errors this library raises on purpose."""


class InputDataError(ChronofuseError, ValueError):
    """Bad input data: names the source (file and line, or field) so a user can find and fix it.

    Parameters
    ----------
    message : str
        What is wrong.
    source : str, optional
        The file path, or the name of the array/field.
    line : int, optional
        1-based line number in ``source`` where the problem is.
    """

    def __init__(self, message: str, source: str | None = None, line: int | None = None):
        self.message = message
        self.source = source
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.source is not None:
            where = f"{self.source}"
            if self.line is not None:
                where += f":{self.line}"
            where += ": "
        return f"{where}{self.message}"


def check_scalar(
    x,
    name: str,
    *,
    min_val: float | None = None,
    max_val: float | None = None,
    include_min: bool = True,
    include_max: bool = True,
    integer: bool = False,
) -> float | int:
    """Check that ``x`` is a finite real scalar within bounds; return it unchanged.

    Raises ``ValueError`` like ``"rate_hz == -1, must be > 0"``.
    """
    if isinstance(x, bool) or not isinstance(x, (Real, np.integer, np.floating)):
        raise TypeError(f"{name} == {x!r}, must be a real number")
    if integer and not float(x).is_integer():
        raise ValueError(f"{name} == {x}, must be an integer")
    if not math.isfinite(float(x)):
        raise ValueError(f"{name} == {x}, must be finite")
    if min_val is not None:
        bad = x < min_val if include_min else x <= min_val
        if bad:
            op = ">=" if include_min else ">"
            raise ValueError(f"{name} == {x}, must be {op} {min_val}")
    if max_val is not None:
        bad = x > max_val if include_max else x >= max_val
        if bad:
            op = "<=" if include_max else "<"
            raise ValueError(f"{name} == {x}, must be {op} {max_val}")
    return x


def check_array(
    a,
    name: str,
    *,
    ndim: int | tuple[int, ...] = 1,
    allow_nan: bool = False,
    min_length: int = 0,
    dtype=np.float64,
) -> np.ndarray:
    """Return ``a`` as a float64 array of the given dimensionality; never reshape.

    NaN marks a missing value and is accepted only with ``allow_nan``; infinities are always rejected.
    """
    arr = np.asarray(a, dtype=dtype)
    ndims = (ndim,) if isinstance(ndim, int) else ndim
    if arr.ndim not in ndims:
        raise ValueError(f"{name} has shape {arr.shape}, must have {' or '.join(map(str, ndims))} dimension(s)")
    if arr.shape[-1:] and arr.shape[-1] < min_length or (arr.ndim == 0 and min_length > 0):
        raise ValueError(f"{name} has {arr.shape[-1] if arr.ndim else 0} samples, must have at least {min_length}")
    if np.issubdtype(arr.dtype, np.floating):
        if np.isinf(arr).any():
            raise ValueError(f"{name} contains infinite values")
        if not allow_nan and np.isnan(arr).any():
            first = int(np.flatnonzero(np.isnan(arr.reshape(-1)))[0])
            raise ValueError(f"{name} contains NaN (first at flat index {first}); missing values are not allowed here")
    return arr


def check_choice(x, name: str, choices) -> str:
    """Check that ``x`` is one of ``choices``."""
    if x not in choices:
        raise ValueError(f"{name} == {x!r}, must be one of {sorted(choices)}")
    return x
