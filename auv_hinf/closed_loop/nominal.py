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
:mod:`auv_hinf.closed_loop.region`; thrust bounds follow from the error bounds and the tube.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrust import ThrustBounds, thrust_bounds
from auv_hinf.closed_loop.lyapunov import lmi_heading_lyapunov, lmi_position_lyapunov
from auv_hinf.closed_loop.region import RegionCertificate, certify_region
from auv_hinf.exceptions import DesignError, SolverError, require_finite
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import inflate_envelope
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.bisection import bisect

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

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s), ``> lam``.
    k1 : float
        Position gain (1/s^2), > 0.
    beta : float
        Shift (decay rate) (1/s).
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

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s), ``> lam``.
    k1 : float
        Position gain (1/s^2), > 0.
    sigma : float
        Bound of ``||D(t)||`` (1/s).

    Raises
    ------
    DesignError
        If even ``beta = 0`` fails, i.e. ``sigma >= alpha - lam``.
    """
    b, k = _position_constants(lam, alpha, k1)
    bound = 1.0 / require_finite("sigma", sigma)
    if not shifted_peak(lam, alpha, k1, 0.0) < bound:
        raise DesignError(f"sigma = {sigma!r} >= alpha - lambda = {b!r}: no decay rate is certified")
    return bisect(lambda beta: shifted_peak(lam, alpha, k1, beta) < bound, 0.0, _stable_shift(b, k), atol=DECAY_ATOL)[0]


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
    """Closed-form rate, backed off until the Lyapunov LMI verifies strictly with ``eigvalsh``.

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s), ``> lam``.
    k1 : float
        Position gain (1/s^2), > 0.
    sigma : float
        Bound of ``||D(t)||`` (1/s).
    """
    sup = position_decay_rate(lam, alpha, k1, sigma)
    backoff = DECAY_BACKOFF_RTOL
    for _ in range(DECAY_BACKOFF_TRIES):
        beta = sup * (1.0 - backoff)
        res = lmi_position_lyapunov(lam, alpha, k1, sigma, beta)
        if res is not None:
            return DecayCertificate(beta, sup, res.matrix, res.multiplier, res.max_eig, res.margin)
        backoff *= 10.0
    spread = k1 / (alpha - lam) ** 2  # the loop's stiffness against its damping: the LMI's scales
    raise SolverError(
        f"position Lyapunov LMI did not verify below beta = {sup:.6g} 1/s: k1 = {k1:.6g} 1/s^2 against alpha - "
        f"lambda = {alpha - lam:.6g} 1/s (k1/(alpha - lambda)^2 = {spread:.3g}) sets scales too far apart for the "
        "strict eigenvalue check; a smaller [design] k1 (or a larger alpha) is verifiable"
    )


def lmi_position_decay_rate(lam: float, alpha: float, k1: float, sigma: float) -> float:
    """Position decay rate (1/s) by bisection on the verified LMI alone (cross-check).

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s), ``> lam``.
    k1 : float
        Position gain (1/s^2), > 0.
    sigma : float
        Bound of ``||D(t)||`` (1/s).
    """
    b, k = _position_constants(lam, alpha, k1)
    return _bisect_lmi(
        lambda beta: lmi_position_lyapunov(lam, alpha, k1, sigma, beta) is not None, _stable_shift(b, k)
    )[0]


def _bisect_lmi(feasible: Any, hi: float) -> tuple[float, float]:
    if not feasible(0.0):
        raise DesignError("the Lyapunov LMI is not strictly feasible even at beta = 0")
    return bisect(feasible, 0.0, hi, atol=LMI_DECAY_ATOL)


def heading_decay_upper(k1psi: float, c_lo: float, c_hi: float) -> float:
    """``min over c in [c_lo, c_hi]`` of ``-max Re eig A(c)`` (1/s): no common Q does better.

    ``-max Re eig`` is ``c/2`` up to ``c = 2 sqrt(k1psi)`` and ``(c - sqrt(c^2 - 4 k1psi))/2``
    (decreasing) beyond, so it is unimodal and the minimum is at an end of the interval.

    Parameters
    ----------
    k1psi : float
        Heading position gain (1/s^2).
    c_lo, c_hi : float
        Range of the heading damping ``c`` (1/s).
    """

    def rate(c: float) -> float:
        disc = c * c - 4.0 * k1psi
        return 0.5 * (c - math.sqrt(disc)) if disc > 0 else 0.5 * c

    return min(rate(c_lo), rate(c_hi))


def heading_decay_rate(k1psi: float, c_lo: float, c_hi: float) -> DecayCertificate:
    """Largest beta (1/s) with a common Q: ``A(c)^T Q + Q A(c) + 2 beta Q < 0`` at both vertices.

    Bisection on the generalized-eigenvalue problem (:func:`auv_hinf.closed_loop.lyapunov.lmi_heading_lyapunov`),
    bracketed by :func:`heading_decay_upper`; the feasible end is returned, verified.

    Parameters
    ----------
    k1psi : float
        Heading position gain (1/s^2), > 0.
    c_lo, c_hi : float
        Range of the heading damping ``c`` (1/s), ``0 < c_lo <= c_hi``.

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
    "DECAY_ATOL",
    "DECAY_BACKOFF_RTOL",
    "DECAY_BACKOFF_TRIES",
    "LMI_DECAY_ATOL",
    "METHOD",
    "ClosedLoopCertificate",
    "DecayCertificate",
    "closed_loop_certificate",
    "heading_decay_rate",
    "heading_decay_upper",
    "lmi_position_decay_rate",
    "position_decay_certificate",
    "position_decay_rate",
    "shifted_peak",
]
