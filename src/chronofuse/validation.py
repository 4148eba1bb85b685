"""Input validation in one place.

Every check raises an error that names the parameter, its value and what was expected, in the form
``"{name} == {value}, must be {expectation}"`` (the scikit-learn convention). The library's own errors
(:class:`ChronofuseError`, input a user can fix: :class:`InputError`) are the only ones the command line
reports as bad input; an input error names the config field, which the command line maps to its option.
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np


class ChronofuseError(Exception):
    """Base class of the errors this library raises on purpose: each is about its input (a value, a file, a
    model file, an address), never a fault of the library. Anything else escaping a call is a bug."""


class InputError(ChronofuseError, ValueError):
    """Input a user can fix: a bad parameter value or bad data, naming the config field(s), and the file and
    line, so that a user can find and fix it.

    A ``ValueError`` too, so that code catching that keeps working; the command line turns this error (and
    only the library's own errors) into a one-line message and exit status 2.

    Parameters
    ----------
    message : str
        What is wrong. A config field it names is written in braces, ``"{rate_hz} == -1, must be > 0"``,
        and listed in ``fields``: :meth:`render` writes each as the caller calls it (the command line: its
        option, ``--rate``); ``str()`` writes the field's own name.
    source : str, optional
        The file path, or the name of the array/field.
    line : int, optional
        1-based line number in ``source`` where the problem is.
    fields : tuple of str, optional
        The config fields named in ``message`` (in braces).
    """

    def __init__(self, message: str, source: str | None = None, line: int | None = None, *,
                 fields: tuple[str, ...] = ()):
        self.message = message
        self.source = source
        self.line = line
        self.fields = tuple(fields)
        super().__init__(str(self))

    def render(self, label=lambda field: field) -> str:
        """The message with each field written as ``label(field)`` and the file and line in front."""
        text = self.message
        for field in self.fields:
            text = text.replace("{" + field + "}", label(field))
        where = ""
        if self.source is not None:
            where = f"{self.source}"
            if self.line is not None:
                where += f":{self.line}"
            where += ": "
        return f"{where}{text}"

    def __str__(self) -> str:
        return self.render()


#: The earlier name of :class:`InputError` (bad input data naming the file and line), kept for callers.
InputDataError = InputError


class InputWarning(UserWarning):
    """Unusual but valid input, analysed as given: the message names config fields in braces, as
    :class:`InputError`'s does (``warnings.warn(InputWarning("{rate_hz} overrides ...", fields=("rate_hz",)))``),
    so the command line writes them as its options."""

    def __init__(self, message: str, *, fields: tuple[str, ...] = ()):
        self.message = message
        self.fields = tuple(fields)
        super().__init__(str(self))

    def render(self, label=lambda field: field) -> str:
        text = self.message
        for field in self.fields:
            text = text.replace("{" + field + "}", label(field))
        return text

    def __str__(self) -> str:
        return self.render()


def invalid(field: str, value, expectation: str, source: str | None = None) -> InputError:
    """``InputError("{field} == value, must be expectation")``: the scikit-learn form naming a field."""
    return InputError(f"{{{field}}} == {value!r}, must be {expectation}" if isinstance(value, str)
                      else f"{{{field}}} == {value}, must be {expectation}", source, fields=(field,))


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

    Raises :class:`InputError` like ``"rate_hz == -1, must be > 0"`` (naming the field ``name``).
    """
    if isinstance(x, bool) or not isinstance(x, (Real, np.integer, np.floating)):
        raise TypeError(f"{name} == {x!r}, must be a real number")
    if integer and not float(x).is_integer():
        raise invalid(name, x, "an integer")
    if not math.isfinite(float(x)):
        raise invalid(name, x, "finite")
    if min_val is not None:
        bad = x < min_val if include_min else x <= min_val
        if bad:
            op = ">=" if include_min else ">"
            raise invalid(name, x, f"{op} {min_val}")
    if max_val is not None:
        bad = x > max_val if include_max else x >= max_val
        if bad:
            op = "<=" if include_max else "<"
            raise invalid(name, x, f"{op} {max_val}")
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
    A wrong number of dimensions is the caller's mistake (``ValueError``); too few samples, NaN or
    infinities are the data's (:class:`InputError`).
    """
    arr = np.asarray(a, dtype=dtype)
    ndims = (ndim,) if isinstance(ndim, int) else ndim
    if arr.ndim not in ndims:
        raise ValueError(f"{name} has shape {arr.shape}, must have {' or '.join(map(str, ndims))} dimension(s)")
    if arr.shape[-1:] and arr.shape[-1] < min_length or (arr.ndim == 0 and min_length > 0):
        raise InputError(f"{{{name}}} has {arr.shape[-1] if arr.ndim else 0} samples, must have at least {min_length}",
                         fields=(name,))
    if np.issubdtype(arr.dtype, np.floating):
        if np.isinf(arr).any():
            raise InputError(f"{{{name}}} contains infinite values", fields=(name,))
        if not allow_nan and np.isnan(arr).any():
            first = int(np.flatnonzero(np.isnan(arr.reshape(-1)))[0])
            raise InputError(f"{{{name}}} contains NaN (first at flat index {first}); missing values are not allowed "
                             "here", fields=(name,))
    return arr


def check_choice(x, name: str, choices) -> str:
    """Check that ``x`` is one of ``choices``."""
    if x not in choices:
        raise InputError(f"{{{name}}} == {x!r}, must be one of {sorted(choices)}", fields=(name,))
    return x
