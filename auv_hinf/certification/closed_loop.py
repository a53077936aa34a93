"""Closed-loop certificate of the formation controller: decay rates, region, thrust bounds.

With scalar gains the formation law reduces to a per-vehicle law. Under a perfect model,
while vehicle i's body velocities stay in the envelope, its errors obey

* position (``e = p_i - p_id`` in R^2): ``e'' = (lam - alpha) e' + D(t) e' - k1 e``,
  ``D = G_i - lam I``, ``||D(t)|| <= sigma``; nominal map ``w -> e'`` is
  ``T(s) = s / (s^2 + (alpha - lam) s + k1)``;
* heading: ``e_psi'' = -k1psi e_psi - c(t) e_psi'``, ``c = k2psi + d33(r)/m33``.

Decay rates come from the shifted bounded-real lemma (position: the largest beta with
``||T(s - beta)||_inf < 1/sigma``, in closed form) and from a common Lyapunov matrix at the
two vertices of ``c`` (heading, LMI bisection). The start region and its margins are in
:mod:`auv_hinf.certification.region`; thrust bounds follow from the error bounds and the tube.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.certification.margins import ErrorBounds, inflate_envelope
from auv_hinf.certification.region import BOUND_RTOL, RegionCertificate, certify_region
from auv_hinf.design.gains import Gains
from auv_hinf.design.lmi.lyapunov import lmi_heading_lyapunov, lmi_position_lyapunov
from auv_hinf.exceptions import DesignError, SolverError, require_finite
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.reference import ReferenceTube
from auv_hinf.models.vehicle import VehicleParams

#: Absolute width (1/s) at which the closed-form decay-rate bisection stops.
DECAY_ATOL = 1e-12
#: Absolute width (1/s) at which the LMI decay-rate bisections stop (SDP accuracy ~1e-8).
LMI_DECAY_ATOL = 1e-6
#: Relative back-off of beta below the supremum before the Lyapunov LMI is solved, so that
#: it is strictly feasible by more than the solver accuracy; multiplied by 10 per retry.
DECAY_BACKOFF_RTOL = 1e-6
#: Back-off retries before giving up.
DECAY_BACKOFF_TRIES = 4

METHOD = (
    "per-vehicle error loops: shifted bounded-real lemma (position, ||D||<=sigma) and vertex "
    "Lyapunov LMI (heading, c in [c_lo, c_hi]); invariant ellipsoids + interval envelope margins "
    "(first exit, sigma on the envelope inflated by 1e-9)"
)


def _position_constants(lam: float, alpha: float, k1: float) -> tuple[float, float]:
    b = require_finite("alpha", alpha) - require_finite("lambda", lam)
    k = require_finite("k1", k1)
    if k <= 0 or b <= 0:
        raise DesignError(f"need k1 > 0 and alpha - lambda > 0, got k1={k!r}, alpha-lambda={b!r}")
    return b, k


def shifted_peak(lam: float, alpha: float, k1: float, beta: float) -> float:
    """``||T(s - beta)||_inf`` in closed form (s); ``inf`` if ``T(s - beta)`` is unstable.

    ``|T(jw - beta)|^2 = (beta^2 + x)/((K - x)^2 + c^2 x)``, ``x = w^2``,
    ``K = k1 - b beta + beta^2``, ``c = b - 2 beta``, ``b = alpha - lam``. Its stationary
    points solve ``x^2 + 2 beta^2 x - ((K + beta^2)^2 - c^2 beta^2 - beta^4) = 0``, so the
    maximum over ``x >= 0`` is at ``x = 0`` or at ``x = -beta^2 + sqrt((K+beta^2)^2 - c^2 beta^2)``.
    """
    b, k = _position_constants(lam, alpha, k1)
    big_k, c = k - b * beta + beta * beta, b - 2.0 * beta
    if big_k <= 0.0 or c <= 0.0:
        return math.inf
    cands = [0.0]
    rad = (big_k + beta * beta) ** 2 - c * c * beta * beta
    if rad >= 0.0 and math.sqrt(rad) >= beta * beta:
        cands.append(math.sqrt(rad) - beta * beta)
    return math.sqrt(max((beta * beta + x) / ((big_k - x) ** 2 + c * c * x) for x in cands))


def _stable_shift(b: float, k: float) -> float:
    """Largest shift keeping ``s^2 + b s + k`` Hurwitz: minus the slowest pole's real part."""
    disc = b * b - 4.0 * k
    return 0.5 * (b - math.sqrt(disc)) if disc > 0 else 0.5 * b


def position_decay_rate(lam: float, alpha: float, k1: float, sigma: float) -> float:
    """Largest beta (1/s) with ``||T(s - beta)||_inf < 1/sigma``, by bisection on the closed form.

    The peak is non-decreasing in beta (maximum modulus on nested half-planes), so bisection
    finds the supremum; the feasible end of the final bracket (width :data:`DECAY_ATOL`)
    is returned.

    Raises
    ------
    DesignError
        If even ``beta = 0`` fails, i.e. ``sigma >= alpha - lam``.
    """
    b, k = _position_constants(lam, alpha, k1)
    bound = 1.0 / require_finite("sigma", sigma)
    if not shifted_peak(lam, alpha, k1, 0.0) < bound:
        raise DesignError(f"sigma = {sigma!r} >= alpha - lambda = {b!r}: no decay rate is certified")
    lo, hi = 0.0, _stable_shift(b, k)
    while hi - lo > DECAY_ATOL:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if shifted_peak(lam, alpha, k1, mid) < bound else (lo, mid)
    return lo


@dataclass(frozen=True)
class DecayCertificate:
    """Certified exponential decay of one error loop.

    Attributes
    ----------
    rate : float
        Certified decay rate beta (1/s): ``V(t) <= V(0) exp(-2 beta t)`` with the verified
        Lyapunov ``matrix``, so the errors decay like ``exp(-beta t)``.
    supremum : float
        Best rate of the method (1/s): closed-form supremum (position) or the infeasible end
        of the LMI bisection (heading); ``rate`` is below it by the back-off.
    matrix : ndarray, shape (2, 2)
        ``P2`` (acting as ``P2 kron I2`` on ``(e, e')``) or ``Q`` (on ``(e_psi, e_psi')``).
    multiplier : float
        S-procedure multiplier (position) or 0.
    max_eig, margin : float
        Largest eigenvalue of the verified LMI matrix and the round-off margin it cleared.
    """

    rate: float
    supremum: float
    matrix: FloatArray
    multiplier: float
    max_eig: float
    margin: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "rate": self.rate,
            "supremum": self.supremum,
            "matrix": self.matrix.tolist(),
            "multiplier": self.multiplier,
            "max_eig": self.max_eig,
            "margin": self.margin,
        }


def position_decay_certificate(lam: float, alpha: float, k1: float, sigma: float) -> DecayCertificate:
    """Closed-form rate, backed off until the Lyapunov LMI verifies strictly with ``eigvalsh``."""
    sup = position_decay_rate(lam, alpha, k1, sigma)
    backoff = DECAY_BACKOFF_RTOL
    for _ in range(DECAY_BACKOFF_TRIES):
        beta = sup * (1.0 - backoff)
        res = lmi_position_lyapunov(lam, alpha, k1, sigma, beta)
        if res is not None:
            return DecayCertificate(beta, sup, res.matrix, res.multiplier, res.max_eig, res.margin)
        backoff *= 10.0
    raise SolverError(f"position Lyapunov LMI did not verify below beta = {sup!r}")


def lmi_position_decay_rate(lam: float, alpha: float, k1: float, sigma: float) -> float:
    """Position decay rate (1/s) by bisection on the verified LMI alone (cross-check)."""
    b, k = _position_constants(lam, alpha, k1)
    return _bisect_lmi(
        lambda beta: lmi_position_lyapunov(lam, alpha, k1, sigma, beta) is not None, _stable_shift(b, k)
    )[0]


def _bisect_lmi(feasible: Any, hi: float) -> tuple[float, float]:
    if not feasible(0.0):
        raise DesignError("the Lyapunov LMI is not strictly feasible even at beta = 0")
    lo = 0.0
    while hi - lo > LMI_DECAY_ATOL:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if feasible(mid) else (lo, mid)
    return lo, hi


def heading_decay_upper(k1psi: float, c_lo: float, c_hi: float) -> float:
    """``min over c in [c_lo, c_hi]`` of ``-max Re eig A(c)`` (1/s): no common Q does better.

    ``-max Re eig`` is ``c/2`` up to ``c = 2 sqrt(k1psi)`` and ``(c - sqrt(c^2 - 4 k1psi))/2``
    (decreasing) beyond, so it is unimodal and the minimum is at an end of the interval.
    """

    def rate(c: float) -> float:
        disc = c * c - 4.0 * k1psi
        return 0.5 * (c - math.sqrt(disc)) if disc > 0 else 0.5 * c

    return min(rate(c_lo), rate(c_hi))


def heading_decay_rate(k1psi: float, c_lo: float, c_hi: float) -> DecayCertificate:
    """Largest beta (1/s) with a common Q: ``A(c)^T Q + Q A(c) + 2 beta Q < 0`` at both vertices.

    Bisection on the generalized-eigenvalue problem (:func:`auv_hinf.design.lmi.lyapunov.lmi_heading_lyapunov`),
    bracketed by :func:`heading_decay_upper`; the feasible end is returned, verified.

    Raises
    ------
    DesignError
        If ``k1psi <= 0``, ``c_lo <= 0`` or ``c_lo > c_hi``.
    """
    if not (k1psi > 0 and 0 < c_lo <= c_hi):
        raise DesignError(f"need k1psi > 0 and 0 < c_lo <= c_hi, got {k1psi!r}, {c_lo!r}, {c_hi!r}")
    c_range = (float(c_lo), float(c_hi))
    lo, hi = _bisect_lmi(
        lambda beta: lmi_heading_lyapunov(k1psi, c_range, beta) is not None, heading_decay_upper(k1psi, c_lo, c_hi)
    )
    res = lmi_heading_lyapunov(k1psi, c_range, lo)
    if res is None:
        raise SolverError(f"heading Lyapunov LMI did not re-verify at beta = {lo!r}")
    return DecayCertificate(lo, hi, res.matrix, 0.0, res.max_eig, res.margin)


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
    ``matrix`` is ``P`` (n x n), ``row`` the gains ``c`` (e.g. ``[k1, alpha]``).
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


@dataclass(frozen=True)
class ClosedLoopCertificate:
    """Everything certified about the closed loop of one (every) vehicle.

    Attributes
    ----------
    position, heading : DecayCertificate
        Decay of the position loop (for every ``||D(t)|| <= sigma``) and of the heading loop
        (for every ``c(t)`` in ``region.c_range``).
    rate : float
        ``min`` of the two rates (1/s), valid for every start in ``region.region``.
    region : RegionCertificate
    thrust : ThrustBounds
        Thrust bounds over the region.
    method : str
        One-line description.
    """

    position: DecayCertificate
    heading: DecayCertificate
    rate: float
    region: RegionCertificate
    thrust: ThrustBounds
    method: str = METHOD

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "position": self.position.to_dict(),
            "heading": self.heading.to_dict(),
            "rate": self.rate,
            "region": self.region.to_dict(),
            "thrust": self.thrust.to_dict(),
            "method": self.method,
        }


def closed_loop_certificate(
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    *,
    lam: float,
    sigma: float,
) -> ClosedLoopCertificate:
    """Decay rates, largest start region and thrust bounds (see :func:`certify_region`).

    Parameters
    ----------
    params : VehicleParams
        The controller's model (the plant, for the nominal certificate).
    envelope : Envelope
        The operating envelope the vehicles must stay in.
    tube : ReferenceTube
        Bounds of the desired motion over time cells.
    gains : Gains
        The gains of the law.
    lam, sigma : float
        Envelope lambda and the vehicle-coordinate bound of ``||G_i - lam I||`` (1/s).
    """
    region = certify_region(params, envelope, tube, gains, lam=lam, sigma=sigma)
    position = position_decay_certificate(lam, gains.alpha, gains.k1, region.sigma)
    heading = heading_decay_rate(gains.k_psi[0], *region.c_range)
    thrust = thrust_bounds(params, inflate_envelope(envelope), tube, region.bounds, gains)
    return ClosedLoopCertificate(
        position=position, heading=heading, rate=min(position.rate, heading.rate), region=region, thrust=thrust
    )


__all__ = [
    "ClosedLoopCertificate",
    "DecayCertificate",
    "ThrustBounds",
    "closed_loop_certificate",
    "ellipsoid_feedback",
    "heading_decay_rate",
    "heading_decay_upper",
    "lmi_position_decay_rate",
    "position_decay_certificate",
    "position_decay_rate",
    "shifted_peak",
    "thrust_bounds",
]
