"""Envelope margins: from error bounds and a reference tube to distances from the envelope edges.

Vehicle i's body velocities are ``u = S cos(delta + e_psi) + w1``,
``v = -S sin(delta + e_psi) + w2`` (``|w| = ||e'||``) and ``r = psi_d' + e_psi'``, with ``S``
the desired ground speed, ``delta`` the reference's heading offset and ``psi_d'`` its yaw rate
(:class:`~auv_hinf.mission.fleet.ReferenceTube`). Exact interval ``cos``/``sin`` over every tube
cell turn error bounds into sound margins (:func:`envelope_margins`). The first-exit argument
that makes margins ``>= 0`` sufficient is in :mod:`auv_hinf.closed_loop.region`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import DesignError
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.vehicle import VehicleParams

#: Relative inflation of the envelope on which sigma and the c-range are certified (see
#: :mod:`auv_hinf.closed_loop.region`); ~1e6 times the round-off of the margin arithmetic, invisible in sigma.
ENVELOPE_INFLATION_RTOL = 1e-9
#: Heading errors must stay below this (rad): the tube's heading offset then keeps its meaning.
MAX_HEADING_ERROR = 0.5 * math.pi


#: Units of the four tracking errors, by the field names of :class:`ErrorBounds`.
ERROR_UNITS = {"position": "m", "velocity": "m/s", "heading": "rad", "yaw_rate": "rad/s"}


@dataclass(frozen=True)
class ErrorBounds:
    """Bounds of one vehicle's errors over all time (sup_t).

    Attributes
    ----------
    position : float
        ``||p - p_d||``, m.
    velocity : float
        ``||p' - p_d'||``, m/s.
    heading : float
        ``|psi - psi_d|``, rad.
    yaw_rate : float
        ``|r - psi_d'|``, rad/s.
    """

    position: float
    velocity: float
    heading: float
    yaw_rate: float

    def to_dict(self) -> dict[str, float]:
        """JSON-safe dictionary."""
        return asdict(self)


def inflate_envelope(envelope: Envelope, rtol: float = ENVELOPE_INFLATION_RTOL) -> Envelope:
    """The envelope widened by ``rtol * max(1, largest |bound|)`` on every side (m/s, rad/s).

    Parameters
    ----------
    envelope : Envelope
        The envelope; its ``u``, ``v`` and ``r`` ranges are widened, ``psi`` is kept.
    rtol : float
        Relative widening (dimensionless).
    """
    eta = rtol * max(1.0, *(abs(x) for x in (*envelope.u, *envelope.v, *envelope.r)))
    return Envelope(
        u=(envelope.u[0] - eta, envelope.u[1] + eta),
        v=(envelope.v[0] - eta, envelope.v[1] + eta),
        r=(envelope.r[0] - eta, envelope.r[1] + eta),
        psi=envelope.psi,
    )


def heading_c_range(params: VehicleParams, envelope: Envelope, k_psi: tuple[float, float]) -> tuple[float, float]:
    """Range of ``c = k2psi + d33(r)/m33`` (1/s) over the envelope's yaw rates.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters (``m33`` and the yaw damping are used).
    envelope : Envelope
        Operating envelope (its ``r`` range is used).
    k_psi : tuple of float
        Heading gains ``(k1psi, k2psi)`` (1/s^2, 1/s); only ``k2psi`` enters.
    """
    lo, hi = abs_range(*envelope.r)
    base = k_psi[1] + params.d33_lin / params.m33
    return base + params.d33_quad * lo / params.m33, base + params.d33_quad * hi / params.m33


def cos_range(lo: FloatArray, hi: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Exact range of ``cos`` over ``[lo, hi]`` (elementwise).

    Parameters
    ----------
    lo, hi : ndarray
        Ends of the angle intervals (rad), ``lo <= hi``.
    """
    two_pi = 2.0 * math.pi
    top = np.floor(hi / two_pi) >= np.ceil(lo / two_pi)
    bottom = np.floor((hi - math.pi) / two_pi) >= np.ceil((lo - math.pi) / two_pi)
    ca, cb = np.cos(lo), np.cos(hi)
    return np.where(bottom, -1.0, np.minimum(ca, cb)), np.where(top, 1.0, np.maximum(ca, cb))


def _scaled_range(
    s_lo: FloatArray, s_hi: FloatArray, g_lo: FloatArray, g_hi: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Range of ``S g`` for ``S`` in ``[s_lo, s_hi]`` (> 0) and ``g`` in ``[g_lo, g_hi]``."""
    return np.minimum(s_lo * g_lo, s_hi * g_lo), np.maximum(s_lo * g_hi, s_hi * g_hi)


@dataclass(frozen=True)
class Margins:
    """Distances of the body velocities from the envelope edges (positive = inside).

    Attributes
    ----------
    u_hi, u_lo, v_hi, v_lo : float
        ``u_max - sup u``, ``inf u - u_min`` and likewise for sway, m/s.
    r_hi, r_lo : float
        Same for the yaw rate, rad/s.
    """

    u_hi: float
    u_lo: float
    v_hi: float
    v_lo: float
    r_hi: float
    r_lo: float

    @property
    def min(self) -> float:
        """Smallest margin (mixed units: m/s and rad/s)."""
        return float(min(self.u_hi, self.u_lo, self.v_hi, self.v_lo, self.r_hi, self.r_lo))

    @property
    def ok(self) -> bool:
        """All margins ``>= 0``: the velocities stay in the (closed) envelope."""
        return self.min >= 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary with ``min`` and ``ok``."""
        return {**asdict(self), "min": self.min, "ok": self.ok}


#: Names of the six margins, in the column order of :func:`cell_margins`.
MARGIN_NAMES = ("u_hi", "u_lo", "v_hi", "v_lo", "r_hi", "r_lo")


def envelope_margins(tube: ReferenceTube, bounds: ErrorBounds, envelope: Envelope) -> Margins:
    """Sound envelope margins of the tube: :func:`cell_margins` minimised over the cells.

    Parameters
    ----------
    tube : ReferenceTube
        Bounds of the vehicle's desired motion over its time cells.
    bounds : ErrorBounds
        Sup-in-time bounds of the vehicle's errors.
    envelope : Envelope
        Operating envelope.
    """
    return Margins(*(float(x) for x in cell_margins(tube, bounds, envelope).min(axis=0)))


def cell_margins(tube: ReferenceTube, bounds: ErrorBounds, envelope: Envelope) -> FloatArray:
    """Sound envelope margins of every tube cell, shape ``(K, 6)`` in the order :data:`MARGIN_NAMES`.

    The distances of each cell's velocity ranges from the envelope's edges, positive inside.

    Parameters
    ----------
    tube, bounds
        The tube of ``K`` cells and the error bounds, as :func:`cell_velocities` takes them (which
        raises :class:`~auv_hinf.exceptions.DesignError` for a heading bound of ``pi/2`` or more).
    envelope : Envelope
        Operating envelope.
    """
    u_lo, u_hi, v_lo, v_hi, r_lo, r_hi = cell_velocities(tube, bounds)
    out: FloatArray = np.stack(
        [
            envelope.u[1] - u_hi,
            u_lo - envelope.u[0],
            envelope.v[1] - v_hi,
            v_lo - envelope.v[0],
            envelope.r[1] - r_hi,
            r_lo - envelope.r[0],
        ],
        axis=-1,
    )
    return out


def cell_velocities(tube: ReferenceTube, bounds: ErrorBounds) -> tuple[FloatArray, ...]:
    """Per tube cell, the ranges of ``u, v`` (m/s) and ``r`` (rad/s) while the errors stay within ``bounds``.

    Per cell ``theta = delta + e_psi`` lies in ``[offset_lo - E_psi, offset_hi + E_psi]`` and ``S``
    in ``[speed_lo, speed_hi]``; exact interval ``cos``/``sin`` give ``u`` in ``[min S cos theta -
    E_v, max S cos theta + E_v]``, ``v`` in ``[min(-S sin theta) - E_v, max(-S sin theta) + E_v]``
    and ``r`` in ``[yaw_rate_lo - E_r, yaw_rate_hi + E_r]``.

    Parameters
    ----------
    tube : ReferenceTube
        Bounds of the vehicle's desired motion over its ``K`` time cells.
    bounds : ErrorBounds
        Sup-in-time bounds ``E_p, E_v, E_psi, E_r`` of the vehicle's errors (``E_p`` unused).

    Returns
    -------
    tuple of ndarray
        ``(u_lo, u_hi, v_lo, v_hi, r_lo, r_hi)``, each of shape ``(K,)``.

    Raises
    ------
    DesignError
        If ``E_psi >= pi/2`` or a tube speed is not positive.
    """
    if not bounds.heading < MAX_HEADING_ERROR:
        raise DesignError(f"heading error bound {bounds.heading!r} rad must be < pi/2")
    s_lo, s_hi = tube.speed[:, 0], tube.speed[:, 1]
    if np.any(s_lo <= 0):
        raise DesignError("the reference tube's speed must be > 0 in every cell")
    th_lo, th_hi = tube.offset[:, 0] - bounds.heading, tube.offset[:, 1] + bounds.heading
    u_lo, u_hi = _scaled_range(s_lo, s_hi, *cos_range(th_lo, th_hi))
    # -sin(theta) = cos(theta + pi/2)
    v_lo, v_hi = _scaled_range(s_lo, s_hi, *cos_range(th_lo + 0.5 * math.pi, th_hi + 0.5 * math.pi))
    ev, er = bounds.velocity, bounds.yaw_rate
    return (u_lo - ev, u_hi + ev, v_lo - ev, v_hi + ev, tube.yaw_rate[:, 0] - er, tube.yaw_rate[:, 1] + er)


def operating_envelope(tube: ReferenceTube, bounds: ErrorBounds, envelope: Envelope, widen: float) -> Envelope:
    """The body velocities the vehicle can reach while its errors stay within ``bounds``, widened, in ``envelope``.

    The hull over the tube's cells of :func:`cell_velocities`, each range widened by ``widen``
    times the larger modulus of its ends on each side, then intersected with ``envelope``. A
    certificate computed on it holds for the vehicle as long as its velocities stay in it, which a
    first-exit argument closes when the certificate's own bounds lie strictly inside it.

    Parameters
    ----------
    tube : ReferenceTube
        Bounds of the vehicle's desired motion over its time cells.
    bounds : ErrorBounds
        Bounds of the errors (m, m/s, rad, rad/s; ``E_v`` with the current's speed added when the
        velocities are taken through the water).
    envelope : Envelope
        The declared envelope the result is clipped to.
    widen : float
        Relative widening of each range (dimensionless, >= 0).
    """
    u_lo, u_hi, v_lo, v_hi, r_lo, r_hi = cell_velocities(tube, bounds)

    def hull(lo: FloatArray, hi: FloatArray, limits: tuple[float, float]) -> tuple[float, float]:
        a, b = float(lo.min()), float(hi.max())
        pad = widen * max(abs(a), abs(b))
        return max(limits[0], a - pad), min(limits[1], b + pad)

    return Envelope(
        u=hull(u_lo, u_hi, envelope.u), v=hull(v_lo, v_hi, envelope.v), r=hull(r_lo, r_hi, envelope.r), psi=envelope.psi
    )


__all__ = [
    "ENVELOPE_INFLATION_RTOL",
    "ERROR_UNITS",
    "MARGIN_NAMES",
    "MAX_HEADING_ERROR",
    "ErrorBounds",
    "Margins",
    "cell_margins",
    "cell_velocities",
    "cos_range",
    "envelope_margins",
    "heading_c_range",
    "inflate_envelope",
    "operating_envelope",
]
