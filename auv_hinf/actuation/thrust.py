"""Sound bounds of the force and moment the law commands, from bounds of the tracking errors.

:func:`thrust_bounds` bounds the body-frame force per channel over the reference tube while
the errors stay within given bounds (feed-forward, model cancellation, current compensation
and feedback); :func:`ellipsoid_feedback` bounds the feedback term alone on an invariant
ellipsoid, which the robust certificate uses when it is the smaller. Every certificate
(nominal, robust, implementation) reports its thrust through :class:`ThrustBounds`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.quadratic_forms import BOUND_RTOL


@dataclass(frozen=True)
class ThrustBounds:
    """Upper bounds of the commanded thrust magnitudes over every covered start.

    Attributes
    ----------
    force_x, force_y : float
        ``sup |tau_x|``, ``sup |tau_y|`` (N, body frame).
    moment : float
        ``sup |tau_psi|`` (N m).
    """

    force_x: float
    force_y: float
    moment: float

    def to_dict(self) -> dict[str, float]:
        """JSON-safe dictionary."""
        return {"force_x": self.force_x, "force_y": self.force_y, "moment": self.moment}

    def as_tuple(self) -> tuple[float, float, float]:
        """``(force_x, force_y, moment)`` (N, N, N m)."""
        return (self.force_x, self.force_y, self.moment)


def thrust_bounds(
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    bounds: ErrorBounds,
    gains: Gains,
    current: float = 0.0,
    integral: float = 0.0,
    feedback: float | None = None,
) -> ThrustBounds:
    """Sound bounds of ``|tau_x|, |tau_y|, |tau_psi|`` while the errors stay within ``bounds``.

    ``tau_xy = M1 (-alpha R^T e' - k1 R^T e - B R^T p_d' + R^T p_d'')``, so per cell
    ``|tau_x| <= m11 (alpha E_v + k1 E_p + |B_11| S_hi + |B_12| S_hi sin(|offset| + E_psi) +
    |p_d''|)`` (likewise y: ``R^T p_d'`` is the desired velocity in the actual body frame); the
    entries of ``B(|u|, |v|, r)`` are affine, so their moduli peak at the 8 vertices of the box of
    body velocities the vehicle can have in the cell: ``|u| <= S_hi + E_v + |c|`` and
    ``|v| <= S_hi sin(|offset| + E_psi) + E_v + |c|`` (the ground velocity is ``p_d' + e'`` and
    ``p_d'`` points along the desired heading up to the tube's heading offset; the
    water-relative velocity differs by the current ``c``), and ``r`` within the cell's desired
    yaw rate widened by ``E_r``, each intersected with the envelope. ``tau_psi = m33 V - (m11 - m22) u v`` with
    ``|V| <= |psi_d''| + d33_max/m33 |psi_d'| + |k1psi| E_psi + |k2psi| E_r`` (``k2psi`` is
    negative when the heading poles are slower than the yaw damping) and ``|u v|`` bounded on
    the same box.

    Parameters
    ----------
    params : VehicleParams
        The controller's model.
    envelope : Envelope
        The envelope the body velocities stay in.
    tube : ReferenceTube
        Bounds of the desired motion over time cells.
    bounds : ErrorBounds
        Bounds of the tracking errors (m, m/s, rad, rad/s).
    gains : Gains
        The gains of the law.
    current : float
        Bound of the water current's speed (m/s).
    integral : float
        Bound of the integrator state ``|z|`` (m s) when the gains have integral action: the
        feedback then also has ``ki |z|``.
    feedback : float, optional
        A sound bound of the whole feedback ``|alpha e' + k1 e + ki z|`` (m/s^2), e.g. its
        maximum over an invariant ellipsoid (:func:`ellipsoid_feedback`); the smaller of it and
        the sum of the terms' bounds is used.
    """
    s_hi = tube.speed[:, 1]
    a_env, b_env = abs_range(*envelope.u), abs_range(*envelope.v)
    # body velocity = R(psi_d + e_psi)^T (p_d' + e') (+ current): the desired velocity points
    # along the desired heading up to the tube's heading offset, so its sway part is at most
    # S sin(|offset| + E_psi)
    slip = np.minimum(0.5 * np.pi, np.abs(tube.offset).max(axis=1) + bounds.heading)
    extra = bounds.velocity + abs(current)
    a_hi = np.minimum(a_env[1], s_hi + extra)
    b_hi = np.minimum(b_env[1], s_hi * np.sin(slip) + extra)
    a_lo = np.minimum(a_env[0], a_hi)
    b_lo = np.minimum(b_env[0], b_hi)
    r_lo = np.clip(tube.yaw_rate[:, 0] - bounds.yaw_rate, envelope.r[0], envelope.r[1])
    r_hi = np.clip(tube.yaw_rate[:, 1] + bounds.yaw_rate, envelope.r[0], envelope.r[1])
    # |B R^T p_d'| row by row: R^T p_d' = S (cos d, sin d) with |d| <= |offset| + E_psi, and
    # each entry of B is affine in (|u|, |v|, r), so its modulus peaks at a vertex
    # (and, by Cauchy-Schwarz, by ||row|| S; each row takes the smaller of the two bounds)
    entries, norms = _block_bounds(params, (a_lo, a_hi), (b_lo, b_hi), (r_lo, r_hi))  # (K, 2, 2), (K, 2)
    along = s_hi[:, None] * entries[:, :, 0] + (s_hi * np.sin(slip))[:, None] * entries[:, :, 1]  # (K, 2)
    along = np.minimum(along, s_hi[:, None] * norms)
    k_psi = gains.k_psi
    err = abs(gains.alpha) * bounds.velocity + abs(gains.k1) * bounds.position + gains.ki * integral
    if feedback is not None:
        err = min(err, feedback)
    drift = along + tube.accel[:, None]
    fx, fy = np.array([params.m11, params.m22]) * (err + drift.max(axis=0))
    r_abs = np.maximum(np.abs(r_lo), np.abs(r_hi))
    d33_max = params.d33_lin + params.d33_quad * r_abs
    yaw = np.abs(tube.yaw_rate).max(axis=1)
    big_v = tube.yaw_accel + d33_max / params.m33 * yaw
    # |k1psi e + k2psi e'| <= |k1psi| E_psi + |k2psi| E_r: k2psi is negative for slow heading poles
    big_v = big_v + abs(k_psi[0]) * bounds.heading + abs(k_psi[1]) * bounds.yaw_rate
    moment = float(np.max(params.m33 * big_v + abs(params.m11 - params.m22) * a_hi * b_hi))
    k = 1.0 + BOUND_RTOL
    return ThrustBounds(k * float(fx), k * float(fy), k * moment)


def ellipsoid_feedback(matrix: FloatArray, row: FloatArray, level: float) -> float:
    """``max |c^T x|`` over ``{x^T P x <= level}`` for planar errors, ``sqrt(level c^T P^-1 c)``.

    The planar feedback ``F = sum_k c_k x_k`` (each ``x_k`` in R^2, the form is ``P kron I2``)
    obeys ``|F|^2 = sum_axes (c^T x_a)^2 <= (c^T P^-1 c) sum_axes x_a^T P x_a`` (Cauchy-Schwarz
    in the ``P`` inner product), so the bound holds on the whole ellipsoid and is attained on it.

    Parameters
    ----------
    matrix : ndarray, shape (n, n)
        The form ``P``, symmetric positive definite.
    row : ndarray, shape (n,)
        The gains ``c`` (e.g. ``[k1, alpha]``, 1/s^2 and 1/s).
    level : float
        Level of the ellipsoid (negative levels count as 0).
    """
    c = np.asarray(row, dtype=float)
    return float(math.sqrt(max(level, 0.0) * float(c @ np.linalg.solve(matrix, c))))


def _block_bounds(
    params: VehicleParams,
    u: tuple[FloatArray, FloatArray],
    v: tuple[FloatArray, FloatArray],
    r: tuple[FloatArray, FloatArray],
) -> tuple[FloatArray, FloatArray]:
    """Largest entry moduli ``(K, 2, 2)`` and row norms ``(K, 2)`` (1/s) of :func:`body_block` over the box.

    ``u``, ``v``: low and high ``|u|``, ``|v|`` (m/s); ``r``: low and high yaw rate (rad/s), each
    of shape ``(K,)``. Entry ``(0, 0)`` depends on ``|u|`` only, ``(1, 1)`` on ``|v|`` only and
    the off-diagonal ones on ``r`` only, so the maxima over the 8 vertices are maxima over two
    values each, and a row norm ``sqrt(b0^2 + b1^2)`` peaks where both moduli do. The entries
    are computed with the same operations as :func:`body_block`, so the result equals its
    maximum over the vertices to the last bit.
    """
    m11, m22 = params.m11, params.m22
    b00 = np.maximum(*(np.abs(-(params.damping(x, 0.0, 0.0)[0] / m11)) for x in u))
    b11 = np.maximum(*(np.abs(-(params.damping(0.0, x, 0.0)[1] / m22)) for x in v))
    b01 = np.maximum(*(np.abs(-x - (-m22 * x / m11)) for x in r))
    b10 = np.maximum(*(np.abs(x - (m11 * x / m22)) for x in r))
    entries = np.stack([np.stack([b00, b01], -1), np.stack([b10, b11], -1)], -2)
    norms: FloatArray = np.sqrt(entries[..., 0] * entries[..., 0] + entries[..., 1] * entries[..., 1])
    return entries, norms


__all__ = ["ThrustBounds", "ellipsoid_feedback", "thrust_bounds"]
