"""The optional parts a plain ``pip install chronofuse`` leaves out, and the one error a missing one gives.

Each optional package belongs to an extra of ``pyproject.toml``: ``ml`` (PyTorch, scikit-learn: the
residual networks and the graph fusion), ``dask`` (dask and distributed: parameter sweeps) and ``live``
(pyserial: serial receivers). :func:`require` imports the package where a command first needs it and, when
it is missing, raises :class:`MissingExtraError`: one line that names what needed it and the extra that
installs it, which the command line prints and exits 2 on, like any bad input.
"""

from __future__ import annotations

import importlib

from chronofuse.validation import ChronofuseError

__all__ = ["EXTRAS", "MissingExtraError", "require"]

#: Importable module -> (the distribution to install, the extra that installs it).
EXTRAS = {
    "torch": ("torch", "ml"),
    "sklearn": ("scikit-learn", "ml"),
    "dask": ("dask", "dask"),
    "distributed": ("distributed", "dask"),
    "serial": ("pyserial", "live"),
}


class MissingExtraError(ChronofuseError, ImportError):
    """An optional package a command needs is not installed."""


def require(module: str, purpose: str):
    """Import ``module`` (a key of :data:`EXTRAS`) and return it; raise :class:`MissingExtraError` naming
    ``purpose`` and the extra when it is not installed."""
    dist, extra = EXTRAS[module]
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(f"{purpose} needs {dist}, which is not installed: pip install "
                                f"'chronofuse[{extra}]'") from None
