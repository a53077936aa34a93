"""Sound tubes of fleet references: bounds of the desired body-frame motion over time cells.

A :class:`~auv_hinf.mission.fleet.ReferenceTube` bounds, for every time in each cell, the desired
ground speed, the heading offset, the desired yaw rate and the accelerations. The closed-loop
certificate (:mod:`auv_hinf.closed_loop.nominal`) turns these into envelope margins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.mission.fleet import H0_SUP, H1_SUP, FleetReference, ReferenceTube, Shaping, wrap_angle
from auv_hinf.mission.paths import MissionBounds, MissionReference, course_jerk_bound, heading_from_velocity

#: Cap on the cells per vehicle in :func:`shaped_tube` (each array holds cells x N x 2 floats).
MAX_CELLS = 200_000
#: Outward margin of every tube interval relative to the quantity's scale: covers rounding in
#: the cell-centre evaluation (a few ulps, ~1e-15 relative) with a wide margin.
TUBE_RTOL = 1e-9
#: Cells per vehicle of a path-frame tube (:func:`path_frame_tube`): parts of the course-rate range.
PATH_FRAME_CELLS = 64


def mission_tube(ref: MissionReference) -> ReferenceTube:
    """One-cell tube of an unshaped mission, valid for all ``t >= 0``, from its bounds.

    Parameters
    ----------
    ref : MissionReference
        Centre path; every vehicle moves as the centre (inertial offsets, no shaping).

    Returns
    -------
    ReferenceTube
        Speed ``[speed_min, speed_max]`` (m/s), offset ``[0, 0]`` (rad), yaw rate
        ``[turn_rate_min, turn_rate_max]`` (rad/s), accel ``accel_max`` (m/s^2) and yaw
        accel ``turn_accel_max`` (rad/s^2) of :meth:`MissionReference.bounds`.
    """
    b: MissionBounds = ref.bounds()
    return ReferenceTube(
        speed=np.array([[b.speed_min, b.speed_max]]),
        offset=np.zeros((1, 2)),
        yaw_rate=np.array([[b.turn_rate_min, b.turn_rate_max]]),
        accel=np.array([b.accel_max]),
        yaw_accel=np.array([b.turn_accel_max]),
    )


def _interval(val: FloatArray, pad: FloatArray, scale: FloatArray | float) -> FloatArray:
    """``[val - pad, val + pad]`` widened by :data:`TUBE_RTOL` of the scale; shape ``val.shape + (2,)``."""
    m = pad + TUBE_RTOL * (np.abs(val) + pad + scale)
    return np.stack([val - m, val + m], axis=-1)


def _cells(cells: int | None, resolution: float, blend_time: float, lipschitz: float) -> int:
    if cells is not None:
        if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) or cells < 1:
            raise ParameterError(f"cells must be a positive integer, got {cells!r}")
        return int(cells)
    res = require_finite("resolution", resolution)
    if res <= 0:
        raise ParameterError(f"resolution must be > 0 (m/s), got {res!r}")
    return int(min(MAX_CELLS, max(1, math.ceil(blend_time * lipschitz / (2.0 * res)))))


def shaped_tube(fleet: FleetReference, *, cells: int | None = None, resolution: float = 1e-3) -> ReferenceTube:
    """Sound tube of a fleet reference for all ``t >= 0``.

    ``[0, T_b]`` is cut into ``K`` equal cells. Each quantity is evaluated at the cell centre
    and padded by the half-width ``w`` times a bound of its time derivative over the cell:

    * speed ``|p'|``: ``A = accel_max + |dp| sup|h0''|/T_b^2 + |dv| sup|h1''|/T_h >= |p''|``;
    * offset ``delta``: ``D1 = |dpsi| sup|h0'|/T_h + |dr| sup|h1'| >= |delta'|``;
    * yaw rate ``chi' + delta'``: ``chi'' = (v x j)/S^2 - 2 chi' (v . a)/S^2`` gives
      ``|chi''| <= J/S + 2 A^2/S^2`` with ``S`` the cell's speed lower bound and
      ``J = jerk_max + |dp| sup|h0'''|/T_b^3 + |dv| sup|h1'''|/T_h^2 >= |p'''|``; plus
      ``D2 = |dpsi| sup|h0''|/T_h^2 + |dr| sup|h1''|/T_h >= |delta''|``.

    That sum also bounds ``|psi''|`` in the cell, and ``min(A, |p''(centre)| + w J)`` bounds
    ``|p''|``. The sup norms are :data:`~auv_hinf.mission.fleet.H0_SUP` and
    :data:`~auv_hinf.mission.fleet.H1_SUP`. The mission tail (:func:`mission_tube`) covers
    ``t >= T_b``.

    Parameters
    ----------
    fleet : FleetReference
        The reference; without shaping the result is :func:`mission_tube` of its mission.
    cells : int or None
        ``K``; by default the smallest making the speed pad ``T_b A / (2 K)`` at most
        ``resolution`` for every vehicle, multiplied by 4 while a speed lower bound is not
        positive, capped at :data:`MAX_CELLS`.
    resolution : float
        Target speed pad (m/s), > 0.

    Returns
    -------
    ReferenceTube
        Rows in C order of (batch scenario, vehicle, cell), then one mission-tail row.

    Raises
    ------
    ParameterError
        If ``cells`` or ``resolution`` is invalid, or a speed cannot be bounded away from zero
        (the heading reference may be undefined: lengthen the blend or start closer to the
        mission velocity).
    """
    tail = fleet_tube(fleet.unshaped())
    sh = fleet.shaping
    if sh is None:
        return tail
    tb, th, n = sh.blend_time, sh.th, fleet.offsets.shape[0]
    dp, dv = sh.dp.reshape(-1, n, 2), sh.dv.reshape(-1, n, 2)
    dpsi, dr = sh.dpsi.reshape(-1, n), sh.dr.reshape(-1, n)
    acc, jerk, d1, d2 = _derivative_bounds(fleet)
    k = _cells(cells, resolution, tb, float(acc.max()))
    while True:  # by default, refine until every speed is bounded away from zero
        try:
            parts = [
                _blend_cells(
                    FleetReference(
                        fleet.mission, fleet.offsets, Shaping(tb, dp[b], dv[b], dpsi[b], dr[b], th), fleet.frame
                    ),
                    tb,
                    k,
                    (acc[b], jerk[b], d1[b], d2[b]),
                    b,
                )
                for b in range(dp.shape[0])
            ]
            return ReferenceTube.concatenate([*parts, tail])
        except _SpeedVanishes:
            if cells is not None or k >= MAX_CELLS:
                raise
            k = min(MAX_CELLS, 4 * k)


def _derivative_bounds(fleet: FleetReference) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Per-vehicle sound bounds ``(A, J, D1, D2)`` of ``|p''|``, ``|p'''|``, ``|delta'|``, ``|delta''|``.

    See :func:`shaped_tube`. Shapes ``(B, N)``, ``B`` the flattened batch of the shaping.
    """
    sh = fleet.shaping
    assert sh is not None
    tb, th, mb, n = sh.blend_time, sh.th, fleet.mission.bounds(), fleet.offsets.shape[0]
    dp, dv = sh.dp.reshape(-1, n, 2), sh.dv.reshape(-1, n, 2)
    dpsi, dr = sh.dpsi.reshape(-1, n), sh.dr.reshape(-1, n)
    dpn, dvn = np.hypot(dp[..., 0], dp[..., 1]), np.hypot(dv[..., 0], dv[..., 1])
    acc = mb.accel_max + dpn * H0_SUP[2] / tb**2 + dvn * H1_SUP[2] / th
    jerk = mb.jerk_max + dpn * H0_SUP[3] / tb**3 + dvn * H1_SUP[3] / th**2
    d1 = np.abs(dpsi) * H0_SUP[1] / th + np.abs(dr) * H1_SUP[1]
    d2 = np.abs(dpsi) * H0_SUP[2] / th**2 + np.abs(dr) * H1_SUP[2] / th
    if fleet.frame == "path":  # |p''| gains |d| (|chi''| + chi'^2); the jerk bound is not needed (see _blend_cells)
        w = max(abs(mb.turn_rate_min), abs(mb.turn_rate_max))
        acc = acc + np.hypot(fleet.offsets[:, 0], fleet.offsets[:, 1]) * (mb.turn_accel_max + w * w)
        jerk = np.full_like(acc, np.inf)
    return acc, jerk, d1, d2


def default_cells(fleet: FleetReference, resolution: float = 1e-3) -> int:
    """The cell count :func:`shaped_tube` would choose for the whole of ``fleet``.

    Use it to tube a large fleet in chunks on one common time grid, so that the margins do
    not depend on how the fleet was split. Returns 1 for an unshaped reference.

    Parameters
    ----------
    fleet : FleetReference
        The whole fleet's reference.
    resolution : float
        Target speed pad (m/s), > 0, as in :func:`shaped_tube`.
    """
    if fleet.shaping is None:
        return 1
    acc = _derivative_bounds(fleet)[0]
    return _cells(None, resolution, fleet.shaping.blend_time, float(acc.max()))


class _SpeedVanishes(ParameterError):
    """The speed lower bound of a cell is not positive."""


def _blend_cells(one: FleetReference, tb: float, k: int, consts: tuple[FloatArray, ...], b: int) -> ReferenceTube:
    """Cells of one unbatched shaped reference over ``[0, T_b]``; ``consts = (A, J, D1, D2)`` per vehicle."""
    acc, jerk, d1, d2 = consts
    hw = 0.5 * tb / k
    tc = (np.arange(k) + 0.5) * (2.0 * hw)
    (_, v, a, j), (dl0, dl1, _) = one.kinematics(tc)
    speed = _interval(np.hypot(v[..., 0], v[..., 1]), hw * acc, 0.0)
    slo = speed[..., 0]
    if not np.all(slo > 0):
        kk, i = np.unravel_index(int(np.argmin(slo)), slo.shape)
        raise _SpeedVanishes(
            f"desired speed of vehicle {i + 1} (scenario {b}) cannot be bounded away from 0 (m/s) "
            f"near t = {tc[kk]:.6g} s (lower bound {slo.min():.3g}) with {k} cells: the heading "
            "reference may be undefined; lengthen blend_time or start closer to the mission velocity"
        )
    chi1: FloatArray
    heading: FloatArray
    offset_rate: FloatArray
    rate: FloatArray
    if one.frame == "path":  # psi_d = chi + delta, chi the course of the centre path q'
        mb = one.mission.bounds()
        w = max(abs(mb.turn_rate_min), abs(mb.turn_rate_max))
        _, q1, q2, q3 = one.mission(tc)
        chi, chi1, _ = (x[:, None] for x in heading_from_velocity(q1, q2, q3))
        # d/dt (chi + delta - atan2(p')) and d/dt (chi' + delta') are bounded by:
        # per cell and vehicle, as every other quantity of the cells (the bound itself is the same in every cell)
        offset_rate, rate = w + d1 + acc / slo, np.broadcast_to(mb.turn_accel_max + d2, slo.shape)
        heading = wrap_angle(chi + dl0 - np.arctan2(v[..., 1], v[..., 0]))
    else:  # psi_d = atan2(p') + delta: the offset is delta
        chi1 = heading_from_velocity(v, a, j)[1]
        offset_rate, rate, heading = d1, jerk / slo + 2.0 * acc**2 / slo**2 + d2, dl0
    return ReferenceTube(
        speed=speed.transpose(1, 0, 2).reshape(-1, 2),
        offset=_interval(heading, hw * offset_rate, np.pi).transpose(1, 0, 2).reshape(-1, 2),
        yaw_rate=_interval(chi1 + dl1, hw * rate, acc / slo + d1).transpose(1, 0, 2).reshape(-1, 2),
        accel=(np.minimum(acc, np.hypot(a[..., 0], a[..., 1]) + hw * jerk) * (1 + TUBE_RTOL)).T.ravel(),
        yaw_accel=(rate * (1 + TUBE_RTOL)).T.ravel(),
    )


def fleet_tube(fleet: FleetReference) -> ReferenceTube:
    """Sound tube of ``fleet`` for all ``t >= 0``.

    Unshaped: :func:`mission_tube` in the inertial frame (every vehicle moves as the centre),
    :func:`path_frame_tube` in the path frame; shaped: :func:`shaped_tube` with its defaults.

    Parameters
    ----------
    fleet : FleetReference
        The reference.
    """
    if fleet.shaping is not None:
        return shaped_tube(fleet)
    if fleet.frame == "path":
        return path_frame_tube(fleet.mission, fleet.offsets)
    return mission_tube(fleet.mission)


def path_frame_tube(mission: MissionReference, offsets: ArrayLike, *, cells: int = PATH_FRAME_CELLS) -> ReferenceTube:
    """Sound tube of every vehicle on path-frame ``offsets`` (m), for all ``t >= 0``.

    Vehicle ``i`` heads along the track (``psi_d = chi``) with desired body velocity
    ``(u_d, v_d) = (|q'| - chi' d_y, chi' d_x)`` and yaw rate ``chi'``
    (:mod:`auv_hinf.mission.fleet`). The cells are not time cells: cell ``k`` holds every time
    at which ``chi'`` lies in the ``k``-th of ``cells`` equal parts of
    ``[turn_rate_min, turn_rate_max]`` (:meth:`MissionReference.bounds`), so ``u_d`` and
    ``v_d`` stay correlated with the turn rate, and the outer vehicle's surge
    ``s (1 + |d_y| chi'max / s)`` is reached exactly at the end cell. Per cell, with
    ``|q'|`` in ``[speed_min, speed_max]``:

    * ``u_d`` and ``v_d`` range over the products of the cell's ``chi'`` with ``d_y``, ``d_x``;
    * speed ``|(u_d, v_d)|`` and offset ``psi_d - atan2(p_i') = -atan2(v_d, u_d)`` follow
      exactly over that box (``atan2`` is monotone in each argument on ``u_d > 0``); a cell whose
      ``u_d`` may be ``<= 0`` (the vehicle stops or reverses) gets speed ``[0, ..]`` and the
      full circle of offsets, which no certificate accepts;
    * ``|p_i''| <= accel_max + |d_i| (turn_accel_max + max chi'^2)``, ``|psi_d''| <= turn_accel_max``.

    Every interval is widened by :data:`TUBE_RTOL` of its scale.

    Parameters
    ----------
    mission : MissionReference
        Centre path.
    offsets : array_like, shape (N, 2)
        ``d_i = (d_x, d_y)`` (m, path frame: along the track, across it).
    cells : int
        Number of parts of the course-rate range.

    Returns
    -------
    ReferenceTube
        ``N * cells`` rows in C order of (vehicle, cell).
    """
    b = mission.bounds()
    off = np.asarray(offsets, dtype=float)
    edges = np.linspace(b.turn_rate_min, b.turn_rate_max, cells + 1)
    w0, w1 = edges[:-1], edges[1:]

    def span(c: FloatArray) -> tuple[FloatArray, FloatArray]:
        return np.minimum(c * w0, c * w1), np.maximum(c * w0, c * w1)

    ty_lo, ty_hi = span(off[:, 1:2])  # (N, K): chi' d_y
    u_lo, u_hi = b.speed_min - ty_hi, b.speed_max - ty_lo
    n_lo, n_hi = span(off[:, 0:1])
    n_min = np.where((n_lo <= 0.0) & (n_hi >= 0.0), 0.0, np.minimum(np.abs(n_lo), np.abs(n_hi)))
    n_max = np.maximum(np.abs(n_lo), np.abs(n_hi))
    moving = u_lo > 0.0
    s_lo = np.where(moving, np.hypot(np.maximum(u_lo, 0.0), n_min), 0.0)
    s_hi = np.hypot(np.maximum(np.abs(u_lo), np.abs(u_hi)), n_max)
    top = np.arctan2(n_hi, np.where(n_hi > 0.0, u_lo, u_hi))  # sup of atan2(v_d, u_d) over the box
    bottom = np.arctan2(n_lo, np.where(n_lo > 0.0, u_hi, u_lo))
    half = 0.5 * (s_hi - s_lo)
    speed = _interval(s_lo + half, half, s_hi)
    mid, pad = -0.5 * (top + bottom), 0.5 * (top - bottom)
    offset = np.where(moving[..., None], _interval(mid, pad, np.pi), np.array([-np.pi, np.pi]))
    rates = np.broadcast_to(
        _interval(0.5 * (w0 + w1), 0.5 * (w1 - w0), abs(b.turn_rate_max) + abs(b.turn_rate_min)), speed.shape
    )
    accel = b.accel_max + np.hypot(off[:, 0], off[:, 1])[:, None] * (b.turn_accel_max + np.maximum(w0**2, w1**2))
    return ReferenceTube(
        speed=speed.reshape(-1, 2),
        offset=offset.reshape(-1, 2),
        yaw_rate=rates.reshape(-1, 2),
        accel=(accel * (1 + TUBE_RTOL)).ravel(),
        yaw_accel=np.full(accel.size, b.turn_accel_max * (1 + TUBE_RTOL)),
    )


@dataclass(frozen=True)
class SlotBounds:
    """Sound bounds of how every slot's speed and course change, for all ``t >= 0`` (:func:`slot_bounds`).

    Attributes
    ----------
    speed_rate : float
        Bound of ``|U'|`` (m/s^2), ``U = |p_i'|`` a slot's speed.
    turn_rate : float
        Bound of a slot's course rate ``|omega| = |p_i' x p_i''| / U^2`` (rad/s).
    turn_accel : float
        Bound of ``|omega'|`` (rad/s^2).
    """

    speed_rate: float
    turn_rate: float
    turn_accel: float


def slot_bounds(
    mission: MissionReference, offsets: ArrayLike, frame: str, *, constant_speed: bool, cells: int = PATH_FRAME_CELLS
) -> SlotBounds:
    """Bounds of every slot's ``|U'|``, ``|omega|`` and ``|omega'|`` along the raw mission, in closed form.

    In the inertial frame every slot moves as the centre: ``omega = chi'`` and ``U = s``, bounded by
    the path's own :meth:`~auv_hinf.mission.paths.MissionReference.bounds`. In the path frame a
    slot ``p_i = q + R(chi) d`` (``d = (d_x, d_y)``) has ``p_i' = (s - chi' d_y) T + chi' d_x N``
    (``T, N`` the path's tangent and normal, ``s`` its speed), and writing out ``p_i''``:

    * ``U U' = (s - chi' d_y) s' + chi'' (chi' |d|^2 - d_y s)``;
    * ``p_i' x p_i'' = chi' U^2 + d_x (chi'' s - chi' s')``, so ``omega = chi' + d_x (chi'' s -
      chi' s') / U^2``;
    * ``omega' = chi'' + d_x (chi3 s - chi' s'') / U^2 - 2 d_x (chi'' s - chi' s') U' / U^3``, with
      ``chi3`` the course's third derivative.

    Each is bounded over the cells of the course rate of :func:`path_frame_tube` (affine in ``chi'``
    and ``s``, so extreme at the corners), with ``U >= |s - chi' d_y|``, ``|chi''|``, ``|s'| <=
    |q''|`` (0 on a path of constant speed), ``|s''| <= |q'''| + |chi'| |q''|`` and ``|chi3|``
    (:func:`~auv_hinf.mission.paths.course_jerk_bound`) from the path's bounds. This is far
    tighter than bounding ``|U'|`` by the whole ``|p_i''|``, the turn's centripetal part included.

    Parameters
    ----------
    mission : MissionReference
        The centre path.
    offsets : array_like, shape (N, 2)
        The slots' offsets (m).
    frame : {"inertial", "path"}
        The offsets' frame.
    constant_speed : bool
        The path's speed is constant by construction (``s' = s'' = 0``).
    cells : int
        Parts of the course-rate range.

    Raises
    ------
    ParameterError
        When a slot may stop (its speed's lower bound is not positive).
    """
    b = mission.bounds()
    w_max = max(abs(b.turn_rate_min), abs(b.turn_rate_max))
    s_rate = 0.0 if constant_speed else b.accel_max
    s_accel = 0.0 if constant_speed else b.jerk_max + w_max * b.accel_max
    if frame != "path":
        return SlotBounds(s_rate, w_max, b.turn_accel_max)
    chi3 = course_jerk_bound(b.speed_min, b.accel_max, b.jerk_max, b.snap_max)
    off = np.asarray(offsets, dtype=float)
    edges = np.linspace(b.turn_rate_min, b.turn_rate_max, cells + 1)
    w = np.stack([edges[:-1], edges[1:]])[None, :, :]  # (1, 2, K): the corners of each cell's chi'
    dx, dy = off[:, 0, None, None], off[:, 1, None, None]
    u = np.stack([b.speed_min - w * dy, b.speed_max - w * dy])  # (2, N, 2, K): s - chi' d_y at the corners
    speed_lo = np.where(np.all(u > 0.0, axis=(0, 2)), np.abs(u).min(axis=(0, 2)), 0.0)  # (N, K): U >= |s - chi' d_y|
    if np.any(speed_lo <= 0.0):
        raise ParameterError("a slot may stop on this mission: its speed's lower bound is not positive")
    wm = np.abs(w).max(axis=1)  # (1, K)
    along = np.abs(u).max(axis=(0, 2))
    lever = np.abs(np.stack([w * (dx * dx + dy * dy) - dy * s for s in (b.speed_min, b.speed_max)])).max(axis=(0, 2))
    u_rate = (along * s_rate + b.turn_accel_max * lever) / speed_lo
    push = np.abs(dx[:, 0]) * (b.turn_accel_max * b.speed_max + wm * s_rate)  # |d_x (chi'' s - chi' s')|
    turn = wm + push / speed_lo**2
    turn_accel = (
        b.turn_accel_max
        + np.abs(dx[:, 0]) * (chi3 * b.speed_max + wm * s_accel) / speed_lo**2
        + 2.0 * push * u_rate / speed_lo**3
    )
    widen = 1.0 + TUBE_RTOL
    return SlotBounds(float(u_rate.max()) * widen, float(turn.max()) * widen, float(turn_accel.max()) * widen)


__all__ = [
    "MAX_CELLS",
    "PATH_FRAME_CELLS",
    "TUBE_RTOL",
    "SlotBounds",
    "default_cells",
    "fleet_tube",
    "mission_tube",
    "path_frame_tube",
    "shaped_tube",
    "slot_bounds",
]
