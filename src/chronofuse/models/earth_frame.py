"""Paths on the rotating Earth seen from the inertial frame, where light-time is solved.

The truth frame of the radio link (:mod:`chronofuse.models.link`) is inertial: light travels in straight
lines at ``c`` and the nodes' clocks are compared with its coordinate time (GNSS time is the same time
scale, realized in the Earth-fixed frame with the Sagnac correction). An aircraft's path is naturally
given in a local east-north-up frame at a geodetic point; :class:`EarthRotating` turns it into the
inertial (Earth-centred) frame whose axes coincide with the Earth-fixed ones at ``t = 0``::

    r_ECEF(t) = r_0 + M r_ENU(t),     r_ECI(t) = R_z(omega t) r_ECEF(t),
    v_ECI(t)  = R_z(omega t) (M v_ENU(t) + omega z x r_ECEF(t)),

with ``M`` the ENU-to-ECEF rotation at the origin (WGS 84 ellipsoid through pymap3d) and ``omega`` the
Earth's rotation rate. A two-way exchange between nodes that move with the Earth then shows the Sagnac
effect: its offset carries ``omega . (r_A x r_B) / c^2`` (1.0 ns for nodes 200 km apart east-west on the
equator), which in the inertial frame is the ``range (u . v_A) / c^2`` term of A's velocity along the
line of sight (see :mod:`chronofuse.sync.measurement`).
"""

from __future__ import annotations

import math

import numpy as np
import pymap3d

from chronofuse.constants import EARTH_ROTATION_RAD_PER_S as OMEGA
from chronofuse.models.kinematics import Trajectory
from chronofuse.validation import check_scalar

__all__ = ["EarthRotating", "enu_to_ecef_matrix"]


def enu_to_ecef_matrix(lat_deg: float, lon_deg: float) -> np.ndarray:
    """The rotation (3, 3) taking east-north-up components at ``(lat, lon)`` to Earth-fixed ones."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-so, -sl * co, cl * co], [co, -sl * so, cl * so], [0.0, cl, sl]])


class EarthRotating:
    """A local-frame :class:`~chronofuse.models.kinematics.Trajectory` (east, north, up from the geodetic
    point ``lat_deg``, ``lon_deg``, ``height_m``) seen in the inertial frame (module docstring).

    Offers ``trials``, ``position_at(t_s)`` and ``velocity_at(t_s)`` like a Trajectory.
    """

    def __init__(self, local: Trajectory, lat_deg: float, lon_deg: float, height_m: float = 0.0):
        check_scalar(lat_deg, "lat_deg", min_val=-90.0, max_val=90.0)
        check_scalar(lon_deg, "lon_deg", min_val=-180.0, max_val=360.0)
        check_scalar(height_m, "height_m", min_val=-1e4, max_val=1e6)
        if not isinstance(local, Trajectory):
            raise TypeError(f"local == {local!r}, must be a Trajectory")
        self.local = local
        self.lat_deg, self.lon_deg, self.height_m = float(lat_deg), float(lon_deg), float(height_m)
        self.origin_ecef_m = np.array(pymap3d.geodetic2ecef(lat_deg, lon_deg, height_m))
        self.enu_to_ecef = enu_to_ecef_matrix(lat_deg, lon_deg)

    @property
    def trials(self) -> int:
        return self.local.trials

    def _ecef(self, t):
        return self.origin_ecef_m + self.local.position_at(t) @ self.enu_to_ecef.T

    @staticmethod
    def _rotate(vec, t):
        c, s = np.cos(OMEGA * t), np.sin(OMEGA * t)
        x, y = vec[..., 0], vec[..., 1]
        return np.stack([c * x - s * y, s * x + c * y, vec[..., 2]], axis=-1)

    def position_at(self, t_s) -> np.ndarray:
        """Inertial positions (trials, k, 3), m, at true times ``t_s`` (trials, k)."""
        t = np.asarray(t_s, dtype=np.float64)
        return self._rotate(self._ecef(t), t)

    def velocity_at(self, t_s) -> np.ndarray:
        """Inertial velocities (trials, k, 3), m/s: the local velocity plus the Earth's ``omega x r``."""
        t = np.asarray(t_s, dtype=np.float64)
        r = self._ecef(t)
        v = self.local.velocity_at(t) @ self.enu_to_ecef.T
        v = v + np.stack([-OMEGA * r[..., 1], OMEGA * r[..., 0], np.zeros_like(r[..., 0])], axis=-1)
        return self._rotate(v, t)
