"""Fleet references: a mission path, formation offsets and a shaped start, with sound tubes.

Vehicle ``i`` tracks ``p_i(t) = off_i + q(t) + c_i(t)`` (inertial frame, m): ``q`` is the
mission path (:mod:`auv_hinf.models.paths`, re-exported here) and ``c_i`` an optional start
correction (:class:`~auv_hinf.models.shaping.Shaping`, also re-exported) that blends the vehicle's
actual initial state into the formation over ``[0, T_b]`` and is identically zero afterwards.
The desired heading is the course of ``p_i'`` plus a blended offset ``delta_i``.
:func:`~auv_hinf.models.tubes.shaped_tube` bounds the motion for all ``t >= 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FORMATION_FRAMES, FloatArray, FormationFrame
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.models.lawnmower import LawnmowerReference
from auv_hinf.models.motion import Motion
from auv_hinf.models.path_frame import PathFrameReference
from auv_hinf.models.paths import (
    CircleReference,
    LineReference,
    MissionReference,
    SineReference,
    heading_from_velocity,
    times,
)
from auv_hinf.models.shaping import Shaping, blend_basis

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
        """One tube holding the cells of all ``tubes``."""
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
        ``chi + delta_i`` (:mod:`auv_hinf.models.path_frame`).
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
        """``[p, p', p'', p''']`` (m .. m/s^3, inertial, shape ``B + (N, 2)``) and
        ``[delta, delta', delta'']`` (rad .. rad/s^2, shape ``B + (N,)``), where ``B`` broadcasts
        ``np.shape(t)`` with the shaping's batch shape."""
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
        """Desired motion at times ``t`` (s), shapes ``B + (N, 2)`` / ``B + (N,)`` (see
        :meth:`kinematics`): ``psi = atan2(p') + delta`` (rad, defined modulo 2 pi),
        ``r = chi' + delta'``, ``r_dot = chi'' + delta''`` with ``chi`` the course of ``p'``;
        in the path frame ``chi`` is the course of the centre path ``q'``.

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

    The centre's velocity, acceleration (m/s, m/s^2) and course ``chi``, ``chi'``, ``chi''``
    (rad, rad/s, rad/s^2, shape (...)) are shared by every vehicle: they are broadcast (read-only
    views), not copied.
    """
    n = offsets.shape[0]
    lead = chi.shape
    # leading (time or scenario) axis fastest in memory, as the batched law wants (auv_hinf.arrays)
    q, qd, qdd = np.asfortranarray(q), np.asfortranarray(qd), np.asfortranarray(qdd)

    def each(x: FloatArray) -> FloatArray:
        return np.broadcast_to(x[..., None, :], (*lead, n, 2))

    def scalar(x: FloatArray) -> FloatArray:
        return np.broadcast_to(x[..., None], (*lead, n))

    return Motion(
        p=offsets + q[..., None, :], v=each(qd), a=each(qdd), psi=scalar(chi), r=scalar(chi1), r_dot=scalar(chi2)
    )


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """``angle`` (rad) wrapped to (-pi, pi]."""
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
            f"initial ground speed must be >= {floor!r} m/s (START_SPEED_RTOL x mission speed), "
            f"got {speed.min()!r}: the heading reference is undefined for a vehicle at rest"
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
    "REFERENCES",
    "START_SPEED_RTOL",
    "FleetReference",
    "Motion",
    "ReferenceTube",
    "reference_from_dict",
    "rigid_motion",
    "shaped_start",
    "wrap_angle",
]
