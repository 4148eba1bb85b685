"""The user-given inputs of :func:`chronofuse.integrity.modes.detect_file` beside the data file: a static
antenna's ECEF position (checked to lie near the Earth's surface) and a noise model saved by an earlier run.

Errors are :class:`~chronofuse.validation.InputDataError` naming the option or the file, so the one message
serves the library and ``chronofuse detect``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from chronofuse.validation import InputDataError, InputError

__all__ = ["EARTH_SURFACE_M", "parse_position", "read_noise_file"]

# Geocentric radius of a static receiver: the WGS 84 polar radius minus the Dead Sea shore, to the
# equatorial radius plus a high mountain (metres).
EARTH_SURFACE_M = (6_350_000.0, 6_390_000.0)


def parse_position(position) -> np.ndarray:
    """A static antenna's ECEF position (3,) in metres from ``"X,Y,Z"`` text or three numbers.

    Raises :class:`InputDataError` when it is not three finite numbers or lies outside
    :data:`EARTH_SURFACE_M` from the Earth's centre (degrees or kilometres given by mistake).
    """
    text = position if isinstance(position, str) else ",".join(map(str, np.ravel(position)))
    try:
        xyz = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise InputError(f"{{position_m}} == {text!r}, must be X,Y,Z in ECEF metres", fields=("position_m",)) from None
    if xyz.shape != (3,) or not np.isfinite(xyz).all():
        raise InputError(f"{{position_m}} == {text!r}, must be three finite numbers X,Y,Z (ECEF metres)",
                         fields=("position_m",))
    radius_m = float(np.linalg.norm(xyz))
    lo_m, hi_m = EARTH_SURFACE_M
    if not lo_m <= radius_m <= hi_m:
        raise InputError(f"{{position_m}} == {text!r}: {radius_m / 1e3:.1f} km from the Earth's centre, must be a "
                         f"static receiver near the surface ({lo_m / 1e3:.0f}..{hi_m / 1e3:.0f} km; "
                         "ECEF metres, not degrees or km)", fields=("position_m",))
    return xyz


def read_noise_file(path: str | Path) -> dict:
    """``{"h0", "hm2", "sigma_rho_m"}`` from a JSON file: a detection document (:func:`detect_file`'s, its
    ``noise``) or the three numbers at the top level, so a model trained once is used on the next run.
    Raises :class:`InputDataError` naming the file when they are not there."""
    import json

    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, ValueError) as err:
        raise InputDataError(f"cannot read a noise model from it: {err}", str(path)) from None
    model = doc.get("noise", doc) if isinstance(doc, dict) else None
    try:
        return {name: float(model[name]) for name in ("h0", "hm2", "sigma_rho_m")}
    except (TypeError, KeyError, ValueError):
        raise InputDataError("expected a JSON object with h0, hm2 and sigma_rho_m (or a detection document "
                             "with its noise)", str(path)) from None
