"""Formations that turn with the path: offsets in the path frame and their exact kinematics.

In the *inertial* frame (the paper's convention, the default) vehicle ``i`` tracks
``p_i = q(t) + d_i``: the Jacobi shape is fixed in the earth frame. In the *path* frame the
offset ``d_i = (d_x, d_y)`` (m; ``x`` along the track, ``y`` across it, on the body y axis: to the left as the
figures draw the plane, starboard in a north-east frame) turns with the
course ``chi = atan2(q')`` of the centre path::

    p_i    = q    + R d
    p_i'   = q'   + chi' S R d
    p_i''  = q''  + chi'' S R d - chi'^2 R d
    p_i''' = q''' + chi''' S R d - 3 chi' chi'' R d - chi'^3 S R d

with ``R = R(chi)`` the 2-D rotation and ``S = [[0, -1], [1, 0]]`` (``R' = chi' S R``, ``S^2 = -I``).
``chi', chi''`` come from ``q', q'', q'''`` (:func:`~auv_hinf.models.paths.heading_from_velocity`),
``chi'''`` also needs ``q''''`` (:func:`course_jerk`).

Desired heading: every vehicle heads along the track, ``psi_d = chi`` (a survey sonar looks
across the track), so every vehicle turns at the centre's rate ``chi'``. Its desired body
velocity is then ``(|q'| - chi' d_y, chi' d_x)``: the vehicle on the outside of a turn of
radius ``rho`` goes faster, ``s (1 + |d_y|/rho)``, the inner one slower, and a vehicle ahead of
or behind the centre slips sideways at ``chi' d_x`` (m/s). The tubes of
:mod:`auv_hinf.models.tubes` bound exactly these, per vehicle, for the certificate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError
from auv_hinf.models.motion import Motion
from auv_hinf.models.paths import MissionReference, heading_from_velocity, times


def course_jerk(v: ArrayLike, a: ArrayLike, j: ArrayLike, snap: ArrayLike) -> FloatArray:
    """Third time derivative of the course ``chi = atan2(v)`` (rad/s^3), shape ``(...)``.

    With ``D = |v|^2``, ``chi' = (v x a)/D`` and ``chi'' = (v x j)/D - 2 chi' (v . a)/D``;
    differentiating once more with ``D' = 2 v . a`` and ``(v x j)' = a x j + v x snap``::

        chi_3 = (a x j + v x snap)/D - 4 chi'' (v . a)/D - 2 chi' (|a|^2 + v . j)/D

    Parameters
    ----------
    v, a, j, snap : array_like, shape (..., 2)
        Velocity (m/s) and its first three derivatives (m/s^2, m/s^3, m/s^4), inertial frame.

    Raises
    ------
    ParameterError
        If any ``|v|`` is zero (the course is undefined) or an input is not finite.
    """
    vv, aa, jj, ss = (np.asarray(x, dtype=float) for x in (v, a, j, snap))
    _, chi1, chi2 = heading_from_velocity(vv, aa, jj)

    def cross(x: FloatArray, y: FloatArray) -> FloatArray:
        out: FloatArray = x[..., 0] * y[..., 1] - x[..., 1] * y[..., 0]
        return out

    def dot(x: FloatArray, y: FloatArray) -> FloatArray:
        out: FloatArray = x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1]
        return out

    num = cross(aa, jj) + cross(vv, ss) - 4.0 * chi2 * dot(vv, aa) - 2.0 * chi1 * (dot(aa, aa) + dot(vv, jj))
    out: FloatArray = num / dot(vv, vv)
    if not np.all(np.isfinite(out)):
        raise ParameterError("snap must be finite (m/s^4)")
    return out


def path_frame_terms(q: list[FloatArray], chi: list[FloatArray], offsets: FloatArray) -> list[FloatArray]:
    """``[p, p', ...]`` of vehicles on path-frame ``offsets`` (see the module docstring).

    Parameters
    ----------
    q : list of ndarray, shape (..., 1, 2) or (..., N, 2)
        ``[q, q', ...]`` of the centre (m .. m/s^k, inertial); as many as wanted (1 to 4).
    chi : list of ndarray, shape (..., N)
        ``[chi, chi', ...]`` (rad .. rad/s^k), at least ``len(q)`` of them.
    offsets : ndarray, shape (N, 2)
        ``d_i`` (m, path frame: along track, across it on the body y axis).

    Returns
    -------
    list of ndarray, shape (..., N, 2)
        ``p, p', p'', p'''`` (as many as ``q``), inertial frame.
    """
    c, s = np.cos(chi[0]), np.sin(chi[0])
    rd = np.stack([c * offsets[:, 0] - s * offsets[:, 1], s * offsets[:, 0] + c * offsets[:, 1]], axis=-1)
    srd = np.stack([-rd[..., 1], rd[..., 0]], axis=-1)

    def w(x: FloatArray) -> FloatArray:
        return x[..., None]

    out: list[FloatArray] = [q[0] + rd]
    if len(q) > 1:
        out.append(q[1] + w(chi[1]) * srd)
    if len(q) > 2:
        out.append(q[2] + w(chi[2]) * srd - w(chi[1] ** 2) * rd)
    if len(q) > 3:
        out.append(q[3] + w(chi[3] - chi[1] ** 3) * srd - w(3.0 * chi[1] * chi[2]) * rd)
    return out


def check_offsets(offsets: ArrayLike, owner: str) -> FloatArray:
    """``offsets`` as a finite ``(N, 2)`` float array (m), or a :class:`ParameterError` naming ``owner``."""
    off = np.asarray(offsets, dtype=float)
    if off.ndim != 2 or off.shape[1] != 2 or off.shape[0] < 1 or not np.all(np.isfinite(off)):
        raise ParameterError(f"{owner}.offsets must be finite with shape (N, 2) (m), got shape {off.shape}")
    return off


@dataclass(frozen=True)
class PathFrameReference:
    """Vehicles on offsets that turn with the path, all heading along the track.

    ``p_i(t) = q(t) + R(chi(t)) d_i`` and ``psi_i = chi = atan2(q')`` (see the module
    docstring). A :class:`~auv_hinf.simulation.law.VehicleMotionSource`: it also evaluates each
    vehicle at its own time, as the decoupled per-vehicle integration needs.

    Parameters
    ----------
    trajectory : MissionReference
        Centre path (inertial, m).
    offsets : array_like, shape (N, 2)
        ``d_i`` (m) in the path frame: ``x`` along the track (ahead > 0), ``y`` across it
        (the body y axis).

    Examples
    --------
    A line-abreast pair on a circle of radius 50 m at 1 m/s: the outer vehicle (10 m outside
    the centre path, on the right of a left turn) goes 1.2 m/s, the inner one 0.8 m/s.

    >>> import numpy as np
    >>> from auv_hinf import CircleReference, PathFrameReference
    >>> ref = PathFrameReference(CircleReference(speed=1.0, radius=50.0), [[0.0, -10.0], [0.0, 10.0]])
    >>> m = ref.motion(7.0)
    >>> [round(float(x), 6) for x in np.hypot(m.v[:, 0], m.v[:, 1])], round(float(m.r[0]), 6)
    ([1.2, 0.8], 0.02)
    """

    trajectory: MissionReference
    offsets: FloatArray

    def __post_init__(self) -> None:
        object.__setattr__(self, "offsets", check_offsets(self.offsets, "PathFrameReference"))

    def kinematics(self, t: ArrayLike, order: int = 3) -> tuple[list[FloatArray], list[FloatArray]]:
        """``[p, p', ..]`` (shape ``t.shape + (N, 2)``, inertial) up to derivative ``order``
        (0 to 3) and ``[chi, chi', chi'']`` (rad .. rad/s^2, shape ``t.shape + (N,)``)."""
        return self._terms(times(t), False, order)

    def _terms(self, tt: FloatArray, per_vehicle: bool, order: int) -> tuple[list[FloatArray], list[FloatArray]]:
        """Terms at times ``tt``: one time for all vehicles, or (``per_vehicle``) ``tt[..., i]`` for vehicle i."""
        q = list(self.trajectory(tt))
        chi = list(heading_from_velocity(q[1], q[2], q[3]))
        if order >= 3:
            chi.append(course_jerk(q[1], q[2], q[3], self.trajectory.snap(tt)))
        if not per_vehicle:  # a vehicle axis of length 1, broadcast against the offsets
            q = [x[..., None, :] for x in q]
            chi = [x[..., None] for x in chi]
        shape = (*chi[0].shape[:-1], self.offsets.shape[0])
        chi_n = [np.broadcast_to(x, shape) for x in chi]
        return path_frame_terms(q[: order + 1], chi_n, self.offsets), chi_n[:3]

    def motion(self, t: float | FloatArray) -> Motion:
        """Desired motion at ``t`` (s; scalar or shape ``(S,)``), all vehicles at the same time."""
        (p, v, a), (chi, chi1, chi2) = self.kinematics(t, order=2)
        return Motion(p=p, v=v, a=a, psi=chi, r=chi1, r_dot=chi2)

    def motion_per_vehicle(self, t: FloatArray) -> Motion:
        """Motion of vehicle ``i`` at ``t[..., i]`` (s), shape ``t.shape + (2,)`` / ``t.shape``."""
        (p, v, a), (chi, chi1, chi2) = self._terms(times(t), True, 2)
        return Motion(p=p, v=v, a=a, psi=chi, r=chi1, r_dot=chi2)


def turn_radius(mission: MissionReference) -> float:
    """Smallest radius of curvature of the centre path (m): ``inf`` for a line.

    Circle: its radius; lawn-mower: its ``turn_radius``; sine ``[s t, A sin(w t)]``: the
    curvature ``|chi'|/|q'|`` peaks at the crests (``|q'| = s``, ``chi' = A w^2/s``), so the
    radius is ``s^2/(A w^2)``.
    """
    d = mission.to_dict()
    kind = d["kind"]
    if kind == "circle":
        return float(d["radius"])
    if kind == "lawnmower":
        return float(d["turn_radius"])
    if kind == "sine" and d["amplitude"] > 0:
        return float(d["speed"] ** 2 / (d["amplitude"] * d["omega"] ** 2))
    return math.inf


def with_turn_radius(mission: MissionReference, radius: float) -> dict[str, Any]:
    """Parameters (``to_dict`` form) of the same mission with smallest radius of curvature ``radius`` (m).

    The speed is kept. A lawn-mower's ``spacing`` is raised, if needed, to the two turns it
    must hold (``2 D``, about ``3.97 R``; 4 R is used). A line has no turn (returned unchanged).
    """
    d = dict(mission.to_dict())
    kind = d["kind"]
    if kind == "circle":
        d["radius"] = radius
    elif kind == "lawnmower":
        d["turn_radius"] = radius
        d["spacing"] = max(d["spacing"], 4.0 * radius)
    elif kind == "sine":
        d["amplitude"] = d["speed"] ** 2 / (radius * d["omega"] ** 2)
    return d


__all__ = ["PathFrameReference", "course_jerk", "path_frame_terms", "turn_radius", "with_turn_radius"]
