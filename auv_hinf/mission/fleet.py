"""Fleet references: a mission path, the formation offsets (inertial or path frame) and a shaped start.

Vehicle ``i`` tracks ``p_i(t) = q(t) + d_i(t) + c_i(t)`` (inertial frame, m): ``q`` is the
mission path (:mod:`auv_hinf.mission.paths`), ``d_i`` the vehicle's offset and ``c_i`` an
optional start correction (:class:`Shaping`) that blends the vehicle's actual initial state
into the formation over ``[0, T_b]`` and is identically zero afterwards. :class:`Motion` is the
desired motion of every vehicle at one or more times (what a control law tracks).

Offsets. In the *inertial* frame (the paper's convention, the default) ``d_i`` is constant:
the Jacobi shape is fixed in the earth frame. In the *path* frame the offset
``d_i = (d_x, d_y)`` (m; ``x`` along the track, ``y`` across it, on the body y axis: to the left
as the figures draw the plane, starboard in a north-east frame) turns with the course
``chi = atan2(q')`` of the centre path::

    p_i    = q    + R d
    p_i'   = q'   + chi' S R d
    p_i''  = q''  + chi'' S R d - chi'^2 R d
    p_i''' = q''' + chi''' S R d - 3 chi' chi'' R d - chi'^3 S R d

with ``R = R(chi)`` the 2-D rotation and ``S = [[0, -1], [1, 0]]`` (``R' = chi' S R``,
``S^2 = -I``). ``chi', chi''`` come from ``q', q'', q'''``
(:func:`~auv_hinf.mission.paths.heading_from_velocity`), ``chi'''`` also needs ``q''''``
(:func:`course_jerk`). Every vehicle then heads along the track, ``psi_d = chi`` (a survey
sonar looks across the track), and its desired body velocity is ``(|q'| - chi' d_y, chi' d_x)``:
the vehicle on the outside of a turn of radius ``rho`` goes faster, ``s (1 + |d_y|/rho)``, the
inner one slower, and a vehicle ahead of or behind the centre slips sideways at ``chi' d_x``.

Shaped starts. The correction starts at the vehicle's actual mismatch and is blended out to
exactly zero by ``t = T_b`` (:func:`blend_basis`); the desired heading gets a blended offset
``delta_i`` too. :mod:`auv_hinf.mission.tubes` bounds every one of these motions for all
``t >= 0``, per vehicle, for the certificates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike

from auv_hinf._typing import FORMATION_FRAMES, FloatArray, FormationFrame
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.mission.paths import (
    SMOOTHSTEP,
    CircleReference,
    LawnmowerReference,
    LineReference,
    MissionReference,
    SineReference,
    heading_from_velocity,
    poly_sup,
    times,
)


@dataclass(frozen=True)
class Motion:
    """Desired motion of every vehicle at one or more times.

    Shapes broadcast over leading axes: ``(..., N, 2)`` for vectors, ``(..., N)`` for scalars.

    Attributes
    ----------
    p, v, a : ndarray
        Desired inertial position (m), velocity (m/s) and acceleration (m/s^2) of each vehicle.
    psi, r, r_dot : ndarray
        Desired heading (rad), yaw rate (rad/s) and yaw acceleration (rad/s^2) of each vehicle.
    """

    p: FloatArray
    v: FloatArray
    a: FloatArray
    psi: FloatArray
    r: FloatArray
    r_dot: FloatArray


#: Blend basis on ``tau`` in [0, 1]: ``h0 = 1 - b`` (septic smoothstep) and
#: ``h1 = tau (1 - tau)^4 (1 + 4 tau)``: ``h0(0) = 1``, ``h1'(0) = 1``, ``h0'(0) = h1(0) = 0``,
#: ``h0''(0) = h1''(0) = 0`` (the start keeps the mission's initial acceleration), and both
#: vanish at ``tau = 1`` with their first three derivatives. The low degrees keep the peaks
#: of ``|h0'|`` (35/16) and ``|h1'|`` (1, at ``tau = 0``) small.
BLEND_H0 = 1.0 - SMOOTHSTEP


BLEND_H1 = Polynomial([0.0, 1.0]) * Polynomial([1.0, -1.0]) ** 4 * Polynomial([1.0, 4.0])


#: ``sup |h0^(k)|`` and ``sup |h1^(k)|`` on [0, 1], ``k = 0..3``, from the coefficients.
H0_SUP = np.array([poly_sup(BLEND_H0.deriv(k)) for k in range(4)])


H1_SUP = np.array([poly_sup(BLEND_H1.deriv(k)) for k in range(4)])


#: Coefficients (increasing powers of tau, degree <= 7) of h0, h1 and their first three
#: derivatives, stacked as eight rows (h0 and its derivatives, then h1 and its derivatives):
#: one small matrix product evaluates all eight at every right-hand-side call.
_BLEND_COEFS = np.array(
    [np.pad(p.deriv(k).coef, (0, 8 - len(p.deriv(k).coef))) for p in (BLEND_H0, BLEND_H1) for k in range(4)]
)


def blend_basis(t: FloatArray, blend_time: float) -> tuple[FloatArray, FloatArray]:
    """``d^k h0(t/T_b)/dt^k`` and ``T_b d^k h1(t/T_b)/dt^k``, ``k = 0..3``: shape ``(4,) + t.shape``.

    Exactly zero for ``t >= T_b``. For ``t < 0`` the polynomials are continued (the reference
    is meant for ``t >= 0``; continuing keeps the derivatives consistent across ``t = 0``).

    Parameters
    ----------
    t : ndarray
        Times (s).
    blend_time : float
        ``T_b`` (s), > 0.
    """
    tau = np.asarray(t, dtype=float) / blend_time
    if np.all(tau >= 1.0):
        zero = np.zeros((4, *tau.shape))
        return zero, zero.copy()
    live = tau < 1.0
    powers = np.minimum(tau, 1.0)[..., None] ** np.arange(8)
    vals = np.where(live, np.moveaxis(powers @ _BLEND_COEFS.T, -1, 0), 0.0)  # (8,) + t.shape
    shape = (4,) + (1,) * tau.ndim
    scale0 = (blend_time ** -np.arange(4.0)).reshape(shape)
    scale1 = (blend_time ** (1.0 - np.arange(4.0))).reshape(shape)
    return vals[:4] * scale0, vals[4:] * scale1


@dataclass(frozen=True)
class Shaping:
    """Start correction of a fleet reference, blended out over ``[0, T_b]``.

    ``c_i(t) = dp_i h0(t/T_b) + T_h dv_i h1(t/T_h)`` is added to the desired position (m) and
    ``delta_i(t) = dpsi_i h0(t/T_h) + T_h dr_i h1(t/T_h)`` to the desired heading (rad); both
    vanish for ``t >= T_b`` (basis :data:`BLEND_H0`, :data:`BLEND_H1`). The position error is
    blended out slowly, over ``T_b``; the velocity and heading mismatches over the shorter
    turn time ``T_h``, so that the initial velocity error is not extrapolated over the whole
    blend (a vehicle 20 m off its slot moving 2 m/s the wrong way would otherwise be sent
    ``T_b * 2 m/s`` further before turning back). Leading batch axes ``...`` hold independent
    scenarios.

    Parameters
    ----------
    blend_time : float
        ``T_b`` (s), > 0.
    dp, dv : array_like, shape (..., N, 2)
        Position (m) and velocity (m/s) corrections at ``t = 0``, inertial frame.
    dpsi, dr : array_like, shape (..., N)
        Heading (rad) and yaw-rate (rad/s) offsets at ``t = 0``.
    turn_time : float or None
        ``T_h`` (s), ``0 < T_h <= T_b``; ``None`` means ``T_b``.
    """

    blend_time: float
    dp: FloatArray
    dv: FloatArray
    dpsi: FloatArray
    dr: FloatArray
    turn_time: float | None = None

    def __post_init__(self) -> None:
        tb = require_finite("Shaping.blend_time", self.blend_time)
        if tb <= 0:
            raise ParameterError(f"Shaping.blend_time must be > 0 (s), got {tb!r}")
        object.__setattr__(self, "blend_time", tb)
        th = tb if self.turn_time is None else require_finite("Shaping.turn_time", self.turn_time)
        if not 0 < th <= tb:
            raise ParameterError(f"Shaping.turn_time must be in (0, blend_time = {tb!r}] (s), got {th!r}")
        object.__setattr__(self, "turn_time", th)
        dp = np.asarray(self.dp, dtype=float)
        if dp.ndim < 2 or dp.shape[-1] != 2:
            raise ParameterError(f"Shaping.dp must have shape (..., N, 2) (m), got {dp.shape}")
        for name, shape in (("dp", dp.shape), ("dv", dp.shape), ("dpsi", dp.shape[:-1]), ("dr", dp.shape[:-1])):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != shape or not np.all(np.isfinite(arr)):
                raise ParameterError(f"Shaping.{name} must be finite with shape {shape}, got {arr!r}")
            object.__setattr__(self, name, arr)

    def terms(self, t: ArrayLike) -> tuple[list[FloatArray], list[FloatArray]]:
        """Position and heading corrections and their derivatives at times ``t``.

        ``[c, c', c'', c''']`` (m .. m/s^3, inertial, shape ``B + (N, 2)``) and
        ``[delta, delta', delta'']`` (rad .. rad/s^2, shape ``B + (N,)``); ``B`` broadcasts
        ``np.shape(t)`` with the batch shape.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        tt = times(t)
        h0, _ = blend_basis(tt, self.blend_time)
        g0, g1 = blend_basis(tt, self.th)
        c = [h0[k][..., None, None] * self.dp + g1[k][..., None, None] * self.dv for k in range(4)]
        d = [g0[k][..., None] * self.dpsi + g1[k][..., None] * self.dr for k in range(3)]
        return c, d

    @property
    def th(self) -> float:
        """The turn time ``T_h`` (s) as a float."""
        return float(self.turn_time if self.turn_time is not None else self.blend_time)


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
    """``offsets`` as a finite ``(N, 2)`` float array (m), or a :class:`ParameterError` naming ``owner``.

    Parameters
    ----------
    offsets : array_like, shape (N, 2)
        Formation offsets (m), ``N >= 1``.
    owner : str
        Name of the class or setting the offsets belong to, for the message.
    """
    off = np.asarray(offsets, dtype=float)
    if off.ndim != 2 or off.shape[1] != 2 or off.shape[0] < 1 or not np.all(np.isfinite(off)):
        raise ParameterError(f"{owner}.offsets must be finite with shape (N, 2) (m), got shape {off.shape}")
    return off


@dataclass(frozen=True)
class PathFrameReference:
    """Vehicles on offsets that turn with the path, all heading along the track.

    ``p_i(t) = q(t) + R(chi(t)) d_i`` and ``psi_i = chi = atan2(q')`` (see the module
    docstring). A :class:`~auv_hinf.law.formation_law.VehicleMotionSource`: it also evaluates each
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
        """Desired positions and their derivatives, and the course and its derivatives, at ``t``.

        ``[p, p', ..]`` (m .. m/s^k, shape ``t.shape + (N, 2)``, inertial) up to derivative
        ``order`` and ``[chi, chi', chi'']`` (rad .. rad/s^2, shape ``t.shape + (N,)``).

        Parameters
        ----------
        t : array_like
            Times (s), finite; one time for all vehicles.
        order : int
            Highest derivative of ``p`` returned, 0 to 3.
        """
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
        """Desired motion at ``t`` (s; scalar or shape ``(S,)``), all vehicles at the same time.

        Parameters
        ----------
        t : float or ndarray
            Times (s), finite.
        """
        (p, v, a), (chi, chi1, chi2) = self.kinematics(t, order=2)
        return Motion(p=p, v=v, a=a, psi=chi, r=chi1, r_dot=chi2)

    def motion_per_vehicle(self, t: FloatArray) -> Motion:
        """Motion of vehicle ``i`` at ``t[..., i]`` (s), shape ``t.shape + (2,)`` / ``t.shape``.

        Parameters
        ----------
        t : ndarray, shape (..., N)
            Time of each vehicle (s), finite.
        """
        (p, v, a), (chi, chi1, chi2) = self._terms(times(t), True, 2)
        return Motion(p=p, v=v, a=a, psi=chi, r=chi1, r_dot=chi2)


def turn_radius(mission: MissionReference) -> float:
    """Smallest radius of curvature of the centre path (m): ``inf`` for a line.

    Circle: its radius; lawn-mower: its ``turn_radius``; sine ``[s t, A sin(w t)]``: the
    curvature ``|chi'|/|q'|`` peaks at the crests (``|q'| = s``, ``chi' = A w^2/s``), so the
    radius is ``s^2/(A w^2)``.

    Parameters
    ----------
    mission : MissionReference
        Centre path; read through its ``to_dict()``.
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

    Parameters
    ----------
    mission : MissionReference
        Centre path; read through its ``to_dict()``.
    radius : float
        New smallest radius of curvature (m).
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


def turn_radius_changes(mission: MissionReference, radius: float) -> dict[str, float]:
    """The ``[reference]`` values that give ``mission`` the smallest radius of curvature ``radius`` (m).

    The keys :func:`with_turn_radius` changes, with their new values: a circle's ``radius``, a
    lawn-mower's ``turn_radius`` (and its ``spacing`` when the turns need more), a sine's
    ``amplitude``; empty for a line.

    Parameters
    ----------
    mission : MissionReference
        Centre path; read through its ``to_dict()``.
    radius : float
        New smallest radius of curvature (m).
    """
    before = mission.to_dict()
    after = with_turn_radius(mission, radius)
    return {k: float(v) for k, v in after.items() if k != "kind" and v != before.get(k)}


#: A shaped start needs each initial ground speed to be at least this fraction of the
#: mission's minimum speed: the course of a vehicle at rest is undefined, and at 1e-3 of the
#: mission speed the yaw-rate reference ``|p''|/|p'|`` is already 1000 times the mission's.
START_SPEED_RTOL = 1e-3


@dataclass(frozen=True)
class ReferenceTube:
    """Sound bounds of the desired body-frame motion over a set of time cells.

    Every field holds one row per cell (cells of all vehicles may be concatenated). Each
    bound holds for *every* time in its cell, not only at sample points.

    Attributes
    ----------
    speed : ndarray, shape (K, 2)
        ``[lo, hi]`` of the desired ground speed ``|p_d'|`` (m/s); ``lo > 0`` is required
        for the heading reference to be defined.
    offset : ndarray, shape (K, 2)
        ``[lo, hi]`` of the heading offset ``delta = psi_d - atan2(p_d')`` (rad); zero on an
        unshaped mission reference.
    yaw_rate : ndarray, shape (K, 2)
        ``[lo, hi]`` of the desired yaw rate ``psi_d'`` (rad/s).
    accel : ndarray, shape (K,)
        Upper bound of ``|p_d''|`` (m/s^2).
    yaw_accel : ndarray, shape (K,)
        Upper bound of ``|psi_d''|`` (rad/s^2).
    """

    speed: FloatArray
    offset: FloatArray
    yaw_rate: FloatArray
    accel: FloatArray
    yaw_accel: FloatArray

    def __post_init__(self) -> None:
        for name in ("speed", "offset", "yaw_rate"):
            arr = np.atleast_2d(np.asarray(getattr(self, name), dtype=float))
            object.__setattr__(self, name, arr)
        for name in ("accel", "yaw_accel"):
            object.__setattr__(self, name, np.atleast_1d(np.asarray(getattr(self, name), dtype=float)))

    @staticmethod
    def concatenate(tubes: list[ReferenceTube]) -> ReferenceTube:
        """One tube holding the cells of all ``tubes``.

        Parameters
        ----------
        tubes : list of ReferenceTube
            The tubes, whose cells are stacked in order.
        """
        return ReferenceTube(
            speed=np.concatenate([t.speed for t in tubes]),
            offset=np.concatenate([t.offset for t in tubes]),
            yaw_rate=np.concatenate([t.yaw_rate for t in tubes]),
            accel=np.concatenate([t.accel for t in tubes]),
            yaw_accel=np.concatenate([t.yaw_accel for t in tubes]),
        )


@dataclass(frozen=True)
class FleetReference:
    """Desired motion of a fleet: mission path, formation offsets and optional shaped start.

    Parameters
    ----------
    mission : MissionReference
        Centre path ``q(t)``.
    offsets : array_like, shape (N, 2)
        Offset of each vehicle from the centre (m), in ``frame``.
    shaping : Shaping or None
        Start correction (see :func:`shaped_start`); ``None`` for the plain mission.
    frame : {"inertial", "path"}
        ``"inertial"`` (the paper): ``p_i = q + d_i``, heading ``atan2(p_i') + delta_i``;
        ``"path"``: the offsets turn with the course, ``p_i = q + R(chi) d_i``, heading
        ``chi + delta_i`` (:mod:`auv_hinf.mission.fleet`).
    """

    mission: MissionReference
    offsets: FloatArray
    shaping: Shaping | None = None
    frame: FormationFrame = "inertial"

    def __post_init__(self) -> None:
        off = np.asarray(self.offsets, dtype=float)
        if off.ndim != 2 or off.shape[1] != 2 or off.shape[0] < 1 or not np.all(np.isfinite(off)):
            raise ParameterError(f"FleetReference.offsets must be finite with shape (N, 2) (m), got {off!r}")
        if self.shaping is not None and self.shaping.dp.shape[-2] != off.shape[0]:
            raise ParameterError(f"shaping is for {self.shaping.dp.shape[-2]} vehicles, offsets for {off.shape[0]}")
        if self.frame not in FORMATION_FRAMES:
            raise ParameterError(f"FleetReference.frame must be one of {FORMATION_FRAMES}, got {self.frame!r}")
        object.__setattr__(self, "offsets", off)

    def unshaped(self) -> FleetReference:
        """The same mission, offsets and frame without the start shaping."""
        return FleetReference(self.mission, self.offsets, None, self.frame)

    def kinematics(self, t: ArrayLike) -> tuple[list[FloatArray], list[FloatArray]]:
        """Desired positions and their derivatives, and the heading offsets and theirs, at ``t``.

        ``[p, p', p'', p''']`` (m .. m/s^3, inertial, shape ``B + (N, 2)``) and
        ``[delta, delta', delta'']`` (rad .. rad/s^2, shape ``B + (N,)``, zero without
        shaping), where ``B`` broadcasts ``np.shape(t)`` with the shaping's batch shape.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        tt = times(t)
        if self.frame == "path":
            base, _ = PathFrameReference(self.mission, self.offsets).kinematics(tt)
            if self.shaping is None:
                return base, [np.zeros(base[0].shape[:-1])] * 3
            c, d = self.shaping.terms(tt)
            return [base[k] + c[k] for k in range(4)], d
        q = [x[..., None, :] for x in self.mission(tt)]
        if self.shaping is None:
            shape = (*tt.shape, self.offsets.shape[0], 2)
            zero: FloatArray = np.zeros(shape[:-1])
            out: list[FloatArray] = [self.offsets + q[0], *(np.broadcast_to(x, shape).copy() for x in q[1:])]
            return out, [zero] * 3
        c, d = self.shaping.terms(tt)
        out = [(self.offsets + q[0]) + c[0], *(q[k] + c[k] for k in range(1, 4))]
        return out, d

    def motion(self, t: ArrayLike) -> Motion:
        """Desired motion at times ``t``, shapes ``B + (N, 2)`` / ``B + (N,)`` (see :meth:`kinematics`).

        ``psi = atan2(p') + delta`` (rad, defined modulo 2 pi), ``r = chi' + delta'``,
        ``r_dot = chi'' + delta''`` with ``chi`` the course of ``p'``; in the path frame ``chi``
        is the course of the centre path ``q'``.

        Parameters
        ----------
        t : array_like
            Times (s), finite.

        Raises
        ------
        ParameterError
            If a desired velocity is zero (heading undefined) or a time is not finite.
        """
        if self.frame == "path":
            plain = PathFrameReference(self.mission, self.offsets)
            if self.shaping is None:
                return plain.motion(times(t))
            (p, v, a), course = plain.kinematics(times(t), order=2)
            c, d = self.shaping.terms(times(t))
            return Motion(p + c[0], v + c[1], a + c[2], course[0] + d[0], course[1] + d[1], course[2] + d[2])
        if self.shaping is None:  # every vehicle moves with the centre: evaluate it once per time
            tt = times(t)
            q, qd, qdd, qddd = self.mission(tt)
            chi, chi1, chi2 = heading_from_velocity(qd, qdd, qddd)
            return rigid_motion(self.offsets, q, qd, qdd, chi, chi1, chi2)
        (p, v, a, j), (d0, d1, d2) = self.kinematics(t)
        chi, chi1, chi2 = heading_from_velocity(v, a, j)
        return Motion(p=p, v=v, a=a, psi=chi + d0, r=chi1 + d1, r_dot=chi2 + d2)


def rigid_motion(
    offsets: FloatArray,
    q: FloatArray,
    qd: FloatArray,
    qdd: FloatArray,
    chi: FloatArray,
    chi1: FloatArray,
    chi2: FloatArray,
) -> Motion:
    """Motion of vehicles on fixed ``offsets (N, 2)`` (m) around a centre moving as ``q`` (..., 2).

    The centre's velocity, acceleration and course are shared by every vehicle: they are
    broadcast (read-only views), not copied.

    Parameters
    ----------
    offsets : ndarray, shape (N, 2)
        Vehicle offsets from the centre (m, inertial frame).
    q, qd, qdd : ndarray, shape (..., 2)
        Position (m), velocity (m/s) and acceleration (m/s^2) of the centre, inertial frame.
    chi, chi1, chi2 : ndarray, shape (...)
        Course of ``qd`` (rad) and its first two derivatives (rad/s, rad/s^2): the desired
        heading, yaw rate and yaw acceleration of every vehicle.
    """
    n = offsets.shape[0]
    lead = chi.shape
    # leading (time or scenario) axis fastest in memory, as the batched law wants (auv_hinf.numerics.arrays)
    q, qd, qdd = np.asfortranarray(q), np.asfortranarray(qd), np.asfortranarray(qdd)

    def each(x: FloatArray) -> FloatArray:
        return np.broadcast_to(x[..., None, :], (*lead, n, 2))

    def scalar(x: FloatArray) -> FloatArray:
        return np.broadcast_to(x[..., None], (*lead, n))

    return Motion(
        p=offsets + q[..., None, :], v=each(qd), a=each(qdd), psi=scalar(chi), r=scalar(chi1), r_dot=scalar(chi2)
    )


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """``angle`` (rad) wrapped to (-pi, pi].

    Parameters
    ----------
    angle : array_like
        Angles (rad).
    """
    out: FloatArray = np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)
    return out


def shaped_start(
    mission: MissionReference,
    offsets: ArrayLike,
    initial: ArrayLike,
    blend_time: float,
    current: tuple[float, float] = (0.0, 0.0),
    turn_time: float | None = None,
    frame: FormationFrame = "inertial",
) -> FleetReference:
    """Fleet reference that starts exactly at the vehicles' initial states.

    At ``t = 0`` each vehicle's desired position, ground velocity, heading (mod 2 pi) and yaw
    rate equal its actual ones; for ``t >= blend_time`` the reference is the plain mission.

    Parameters
    ----------
    mission : MissionReference
        Centre path.
    offsets : array_like, shape (N, 2)
        Formation offsets (m, inertial frame).
    initial : array_like, shape (..., N, 6)
        Initial states ``[x, y, psi, u, v, r]`` (m, m, rad, m/s and m/s in the body frame, rad/s).
    blend_time : float
        ``T_b`` (s), > 0.
    current : tuple of float
        Water current (m/s, inertial); the ground velocity is ``R(psi) [u, v] + current``.
    turn_time : float or None
        ``T_h`` (s) of the velocity and heading blends (see :class:`Shaping`); default ``T_b``.
    frame : {"inertial", "path"}
        Frame of the offsets (see :class:`FleetReference`). In the path frame the heading
        offset is taken from the path's course: ``dpsi = wrap(psi(0) - chi(0))`` and
        ``dr = r(0) - chi'(0) - dpsi h0'(0)/T_h``, with ``chi = atan2(q')``.

    Returns
    -------
    FleetReference
        With ``dp = p(0) - off - q(0)``, ``dv = p'(0) - q'(0)``, ``dpsi = wrap(psi(0) -
        atan2(p'(0)))`` and ``dr = (r(0) - chi'(0) - dpsi h0'(0)/T_b) / h1'(0)``, where
        ``chi'(0)`` is the course rate of ``p'(0)`` with ``p''(0) = q''(0) + c''(0)``
        (``c''(0)`` depends on ``dp, dv`` only).

    Raises
    ------
    ParameterError
        On bad shapes or values, or if an initial ground speed is below
        :data:`START_SPEED_RTOL` times the mission's minimum speed.
    """
    off = np.asarray(offsets, dtype=float)
    init = np.asarray(initial, dtype=float)
    if off.ndim != 2 or init.ndim < 2 or init.shape[-2:] != (off.shape[0], 6) or not np.all(np.isfinite(init)):
        raise ParameterError(
            f"initial must be finite with shape (..., N, 6) for offsets of shape (N, 2), "
            f"got {init.shape} and {off.shape}"
        )
    cur = np.asarray(current, dtype=float)
    if cur.shape != (2,) or not np.all(np.isfinite(cur)):
        raise ParameterError(f"current must be 2 finite numbers (m/s), got {current!r}")
    tb = require_finite("blend_time", blend_time)
    if tb <= 0:
        raise ParameterError(f"blend_time must be > 0 (s), got {tb!r}")
    _, q1, q2, q3 = mission(0.0)
    psi, u, v, r = (init[..., k] for k in range(2, 6))
    vel = np.stack([np.cos(psi) * u - np.sin(psi) * v, np.sin(psi) * u + np.cos(psi) * v], axis=-1) + cur
    floor = START_SPEED_RTOL * mission.bounds().speed_min
    speed = np.hypot(vel[..., 0], vel[..., 1])
    if np.any(speed < floor):
        raise ParameterError(
            f"every vehicle's initial ground speed must be at least {floor:.3g} m/s ({START_SPEED_RTOL:g} times "
            f"the mission's slowest speed), got {float(speed.min()):.3g} m/s: the heading reference is undefined "
            "for a vehicle at rest (start the vehicles moving along the mission, or let the run start on the slots)"
        )
    raw = FleetReference(mission, off, None, frame)
    (p0, v0, a0, _), _ = raw.kinematics(0.0)
    dp = init[..., :2] - p0
    dv = vel - v0
    th = tb if turn_time is None else require_finite("turn_time", turn_time)
    h0, _ = blend_basis(np.zeros(1), tb)
    g0, g1 = blend_basis(np.zeros(1), th)
    if frame == "path":
        chi, chi1, _ = heading_from_velocity(q1, q2, q3)
    else:
        chi, chi1, _ = heading_from_velocity(vel, a0 + h0[2, 0] * dp + g1[2, 0] * dv, np.zeros_like(vel))
    dpsi = wrap_angle(psi - chi)
    dr = (r - chi1 - g0[1, 0] * dpsi) / g1[1, 0]
    return FleetReference(mission, off, Shaping(tb, dp, dv, dpsi, dr, th), frame)


#: Mission classes by ``kind``.
REFERENCES: dict[str, type] = {c.kind: c for c in (SineReference, LineReference, CircleReference, LawnmowerReference)}


def reference_from_dict(kind: str, **params: Any) -> MissionReference:
    """Mission reference of ``kind`` (a key of :data:`REFERENCES`) built from ``params``.

    Parameters
    ----------
    kind : str
        ``"sine"``, ``"line"``, ``"circle"`` or ``"lawnmower"``.
    **params : Any
        Constructor arguments of that class (as in its ``to_dict()`` without ``kind``).

    Raises
    ------
    ParameterError
        If ``kind`` is unknown or a parameter is invalid.
    """
    if kind not in REFERENCES:
        raise ParameterError(f"reference kind must be one of {sorted(REFERENCES)}, got {kind!r}")
    try:
        ref: MissionReference = REFERENCES[kind](**params)
    except TypeError as exc:
        raise ParameterError(f"invalid parameters for reference kind {kind!r}: {exc}") from None
    return ref


__all__ = [
    "BLEND_H0",
    "BLEND_H1",
    "H0_SUP",
    "H1_SUP",
    "REFERENCES",
    "START_SPEED_RTOL",
    "FleetReference",
    "Motion",
    "PathFrameReference",
    "ReferenceTube",
    "Shaping",
    "blend_basis",
    "check_offsets",
    "course_jerk",
    "path_frame_terms",
    "reference_from_dict",
    "rigid_motion",
    "shaped_start",
    "turn_radius",
    "turn_radius_changes",
    "with_turn_radius",
    "wrap_angle",
]
