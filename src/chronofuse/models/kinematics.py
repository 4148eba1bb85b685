"""Node kinematics in 3-D: piecewise constant-acceleration trajectories.

One model serves every use: constant velocity (one segment, zero acceleration), constant acceleration
(one segment) and manoeuvres (several segments, each with its own acceleration; position and velocity
are continuous at the segment starts). Positions are in a stated inertial *truth frame*, metres, and
times are seconds of true (coordinate) time since the start of the run; the radio link
(:mod:`chronofuse.models.link`) solves light-time in this frame.

Within segment ``j`` (``t_j <= t < t_{j+1}``)::

    r(t) = r_j + v_j (t - t_j) + a_j (t - t_j)^2 / 2,     v(t) = v_j + a_j (t - t_j)

Arrays carry a leading trial axis of length ``trials`` or 1 (1 = the same path for every trial), so a
Monte Carlo run with one geometry and a training set with a different path per trial use one type.

Manoeuvre profiles: :func:`turn` (a level coordinated turn at a load factor, as many short constant-
acceleration segments whose acceleration stays perpendicular to the velocity) and :func:`climb` (a pull-up
into a climb and back). A path in a local frame on the rotating Earth, seen in the inertial frame, is
:class:`chronofuse.models.earth_frame.EarthRotating` (it offers the same ``position_at``/``velocity_at``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.validation import InputError, check_array, check_scalar

__all__ = ["Trajectory", "constant_velocity", "constant_acceleration", "manoeuvre", "radial_geometry", "turn",
           "climb", "line_of_sight"]


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Trajectory:
    """A piecewise constant-acceleration path.

    Attributes
    ----------
    segment_start_s : ndarray of shape (segments,)
        Start time of each segment, s; strictly increasing, the first is 0 (before it the first segment
        is extrapolated backwards).
    position_m : ndarray of shape (trials or 1, segments, 3)
        Position at each segment start, m.
    velocity_m_s : ndarray of shape (trials or 1, segments, 3)
        Velocity at each segment start, m/s.
    acceleration_m_s2 : ndarray of shape (trials or 1, segments, 3)
        Constant acceleration over each segment, m/s^2.
    """

    segment_start_s: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray

    def __post_init__(self):
        starts = check_array(self.segment_start_s, "segment_start_s", ndim=1, min_length=1)
        if starts[0] != 0.0 or np.any(np.diff(starts) <= 0.0):
            raise ValueError(f"segment_start_s == {starts.tolist()}, must start at 0 and strictly increase")
        shapes = []
        for name in ("position_m", "velocity_m_s", "acceleration_m_s2"):
            arr = check_array(getattr(self, name), name, ndim=3)
            if arr.shape[1:] != (starts.size, 3):
                raise ValueError(f"{name} has shape {arr.shape}, must be (trials, {starts.size}, 3)")
            shapes.append(arr.shape[0])
            object.__setattr__(self, name, _readonly(arr))
        if len(set(shapes) - {1}) > 1:
            raise ValueError(f"trial axes {shapes} of position/velocity/acceleration must agree (or be 1)")
        object.__setattr__(self, "segment_start_s", _readonly(starts))

    @property
    def trials(self) -> int:
        """Length of the trial axis (1 = shared by every trial)."""
        return max(self.position_m.shape[0], self.velocity_m_s.shape[0], self.acceleration_m_s2.shape[0])

    def _segment(self, t_s: np.ndarray):
        t = check_array(t_s, "t_s", ndim=2)
        if self.trials not in (1, t.shape[0]):
            raise ValueError(f"t_s has {t.shape[0]} trials, the trajectory has {self.trials}")
        j = np.clip(np.searchsorted(self.segment_start_s, t, side="right") - 1, 0, None)
        dt = (t - self.segment_start_s[j])[..., None]
        rows = np.arange(t.shape[0])[:, None] if self.trials > 1 else np.zeros((t.shape[0], 1), dtype=np.intp)

        def pick(arr):
            r = rows if arr.shape[0] > 1 else np.zeros_like(rows)
            return arr[r, j]

        return dt, pick(self.position_m), pick(self.velocity_m_s), pick(self.acceleration_m_s2)

    def position_at(self, t_s) -> np.ndarray:
        """Positions at true times ``t_s`` of shape (trials, k): array of shape (trials, k, 3), m."""
        dt, r, v, a = self._segment(np.asarray(t_s, dtype=np.float64))
        return r + v * dt + 0.5 * a * dt * dt

    def velocity_at(self, t_s) -> np.ndarray:
        """Velocities at true times ``t_s`` of shape (trials, k): array of shape (trials, k, 3), m/s."""
        dt, _, v, a = self._segment(np.asarray(t_s, dtype=np.float64))
        return v + a * dt


def _vec(x, name: str) -> np.ndarray:
    arr = check_array(x, name, ndim=(1, 2))
    if arr.shape[-1] != 3:
        raise ValueError(f"{name} has shape {arr.shape}, must be (3,) or (trials, 3)")
    return arr if arr.ndim == 2 else arr[None, :]


def constant_acceleration(position_m, velocity_m_s, acceleration_m_s2) -> Trajectory:
    """One segment from ``t = 0``: each argument of shape (3,) or (trials, 3)."""
    r, v, a = _vec(position_m, "position_m"), _vec(velocity_m_s, "velocity_m_s"), _vec(acceleration_m_s2, "acceleration_m_s2")
    return Trajectory(np.zeros(1), r[:, None, :], v[:, None, :], a[:, None, :])


def constant_velocity(position_m, velocity_m_s) -> Trajectory:
    """Straight-line motion at constant velocity: arguments of shape (3,) or (trials, 3)."""
    v = _vec(velocity_m_s, "velocity_m_s")
    return constant_acceleration(position_m, v, np.zeros_like(v))


def manoeuvre(position_m, velocity_m_s, segment_start_s, acceleration_m_s2) -> Trajectory:
    """A manoeuvre: accelerations ``acceleration_m_s2`` (segments, 3) switched on at ``segment_start_s``.

    Position and velocity are carried continuously across each switch (integrated exactly).
    """
    r0, v0 = _vec(position_m, "position_m"), _vec(velocity_m_s, "velocity_m_s")
    starts = check_array(segment_start_s, "segment_start_s", ndim=1, min_length=1)
    acc = check_array(acceleration_m_s2, "acceleration_m_s2", ndim=2)
    if acc.shape != (starts.size, 3):
        raise ValueError(f"acceleration_m_s2 has shape {acc.shape}, must be ({starts.size}, 3)")
    trials = max(r0.shape[0], v0.shape[0])
    r = np.empty((trials, starts.size, 3))
    v = np.empty((trials, starts.size, 3))
    r[:, 0], v[:, 0] = r0, v0
    for j in range(1, starts.size):
        dt = starts[j] - starts[j - 1]
        r[:, j] = r[:, j - 1] + v[:, j - 1] * dt + 0.5 * acc[j - 1] * dt * dt
        v[:, j] = v[:, j - 1] + acc[j - 1] * dt
    return Trajectory(starts, r, v, np.broadcast_to(acc, (trials, starts.size, 3)).copy())


def radial_geometry(distance_m, radial_velocity_m_s, radial_acceleration_m_s2=0.0) -> tuple[Trajectory, Trajectory]:
    """The paper's two-node geometry: A at rest at the origin, B on the x axis at ``distance_m`` moving
    away at ``radial_velocity_m_s`` (negative: closing) with ``radial_acceleration_m_s2``.

    Each argument is a scalar or an array of shape (trials,). Returns ``(a, b)``.
    """
    d = np.atleast_1d(np.asarray(distance_m, dtype=np.float64))
    v = np.atleast_1d(np.asarray(radial_velocity_m_s, dtype=np.float64))
    acc = np.atleast_1d(np.asarray(radial_acceleration_m_s2, dtype=np.float64))
    for name, arr in (("distance_m", d), ("radial_velocity_m_s", v), ("radial_acceleration_m_s2", acc)):
        if arr.ndim != 1:
            raise ValueError(f"{name} has shape {arr.shape}, must be a scalar or (trials,)")
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name} contains non-finite values")
    if np.any(d < 0.0):
        raise InputError(f"{{distance_m}} == {d.min()}, must be >= 0", fields=("distance_m",))
    n = max(d.size, v.size, acc.size)
    for name, arr in (("distance_m", d), ("radial_velocity_m_s", v), ("radial_acceleration_m_s2", acc)):
        check_scalar(arr.size, f"len({name})", min_val=1)
        if arr.size not in (1, n):
            raise ValueError(f"{name} has {arr.size} values, must have 1 or {n}")
    e = np.array([1.0, 0.0, 0.0])
    a = constant_velocity(np.zeros(3), np.zeros(3))
    b = constant_acceleration(np.broadcast_to(d, (n,))[:, None] * e, np.broadcast_to(v, (n,))[:, None] * e,
                              np.broadcast_to(acc, (n,))[:, None] * e)
    return a, b


STANDARD_GRAVITY_M_S2 = 9.80665


def turn(position_m, velocity_m_s, *, load_factor_g: float, start_s: float, duration_s: float,
         right: bool = True, segment_s: float = 0.05, total_s: float | None = None) -> Trajectory:
    """A level turn at ``load_factor_g`` (horizontal acceleration ``g sqrt(n^2 - 1)``, the coordinated-turn
    relation) from ``start_s`` for ``duration_s``, straight flight before and after.

    The turn is built from segments of ``segment_s`` (at most) with constant acceleration, each taking the
    velocity to the same velocity rotated by ``omega segment_s`` (``omega = a / |v|``): the speed is the same
    at every segment's ends (it dips by ``(omega segment_s)^2 / 8`` relative in between, 1e-5 at 5 g, 250 m/s
    and the default 0.05 s) and the acceleration's size is ``a`` within ``(omega segment_s)^2 / 24``.
    ``position_m``, ``velocity_m_s`` of shape (3,) (one path; ``z`` is up). ``total_s`` (default: the end of
    the turn) only documents the run length.
    """
    check_scalar(load_factor_g, "load_factor_g", min_val=1.0)
    check_scalar(start_s, "start_s", min_val=0.0)
    check_scalar(duration_s, "duration_s", min_val=0.0, include_min=False)
    check_scalar(segment_s, "segment_s", min_val=1e-4, include_min=True)
    r0, v0 = _vec(position_m, "position_m")[0], _vec(velocity_m_s, "velocity_m_s")[0]
    speed = float(np.hypot(v0[0], v0[1]))
    if speed <= 0.0:
        raise InputError(f"{{velocity_m_s}} == {v0.tolist()} has no horizontal part, a level turn ({{manoeuvre}}) "
                         "needs one", fields=("velocity_m_s", "manoeuvre"))
    accel = STANDARD_GRAVITY_M_S2 * np.sqrt(load_factor_g**2 - 1.0)
    n_seg = max(1, int(np.ceil(duration_s / segment_s)))
    starts = [0.0] if start_s > 0.0 else []
    acc_rows = [np.zeros(3)] if start_s > 0.0 else []
    v = v0.astype(float).copy()
    sign = -1.0 if right else 1.0
    dt = duration_s / n_seg
    step = sign * accel / speed * dt  # heading change per segment, rad
    rot = np.array([[np.cos(step), -np.sin(step), 0.0], [np.sin(step), np.cos(step), 0.0], [0.0, 0.0, 1.0]])
    for j in range(n_seg):
        starts.append(start_s + j * dt)
        v_next = rot @ v
        acc_rows.append((v_next - v) / dt)
        v = v_next
    starts.append(start_s + duration_s)
    acc_rows.append(np.zeros(3))
    return manoeuvre(r0, v0, np.asarray(starts), np.asarray(acc_rows))


def climb(position_m, velocity_m_s, *, load_factor_g: float, start_s: float, pull_s: float, hold_s: float) -> Trajectory:
    """A pull-up: vertical acceleration ``g (n - 1)`` for ``pull_s`` from ``start_s``, a constant climb for
    ``hold_s``, and the same push-over back to level flight (piecewise constant acceleration, exact)."""
    check_scalar(load_factor_g, "load_factor_g", min_val=1.0)
    for name, value in (("start_s", start_s), ("pull_s", pull_s), ("hold_s", hold_s)):
        check_scalar(value, name, min_val=0.0)
    up = np.array([0.0, 0.0, STANDARD_GRAVITY_M_S2 * (load_factor_g - 1.0)])
    times = np.array([0.0, start_s, start_s + pull_s, start_s + pull_s + hold_s, start_s + 2 * pull_s + hold_s])
    acc = np.array([np.zeros(3), up, np.zeros(3), -up, np.zeros(3)])
    keep = np.concatenate([[True], np.diff(times) > 0.0])
    return manoeuvre(position_m, velocity_m_s, times[keep], acc[keep])


def line_of_sight(node_a, node_b, t_s):
    """Range (trials, k), m, the unit vector from A to B (trials, k, 3), and the velocities of A and B
    (trials, k, 3), m/s, at true times ``t_s`` (trials, k), in the paths' common frame.

    Where the nodes coincide (range below 1 mm) the line of sight is the direction the range opens along,
    that of the relative velocity (the one-sided limit), so that the range rate there is ``|v_B - v_A|``."""
    rel = node_b.position_at(t_s) - node_a.position_at(t_s)
    v_a, v_b = node_a.velocity_at(t_s), node_b.velocity_at(t_s)
    rng_m = np.linalg.norm(rel, axis=-1)
    near = rng_m < 1e-3
    if np.any(near):
        rel = np.where(near[..., None], v_b - v_a, rel)
    norm = np.linalg.norm(rel, axis=-1)
    u = np.divide(rel, norm[..., None], out=np.zeros_like(rel), where=norm[..., None] > 0.0)
    return rng_m, u, v_a, v_b
