"""Level sets of the 2x2 Lyapunov forms of the error loops: levels, extents, per-start bounds.

A position form acts on the planar pair ``(e, e')`` as ``M kron I2``, a heading form on the
scalar pair ``(e_psi, e_psi')``. The certificates size their regions with :func:`box_level`
and :func:`level_extent`; runs and campaigns evaluate starts with :func:`pair_level` and
:func:`start_bounds`. Every extent is inflated by :data:`BOUND_RTOL` for round-off.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray

#: Relative round-off allowance added to every ellipsoid bound ``sqrt(rho (M^-1)_ii)``
#: (a few ulps of a handful of flops, taken generously).
BOUND_RTOL = 1e-12


def box_level(m: FloatArray, r1: float, r2: float) -> float:
    """Largest ``x^T M x`` over the box ``|x1| <= r1, |x2| <= r2``: ``m11 r1^2 + 2 |m12| r1 r2 + m22 r2^2`` (exact).

    Parameters
    ----------
    m : ndarray, shape (2, 2)
        Symmetric form.
    r1, r2 : float
        Half-widths of the box in ``x1`` and ``x2`` (e.g. m and m/s, or rad and rad/s).
    """
    return float(m[0, 0]) * r1 * r1 + 2.0 * abs(float(m[0, 1])) * r1 * r2 + float(m[1, 1]) * r2 * r2


def level_extent(m: FloatArray, rho: float) -> tuple[float, float]:
    """Sup of ``|x1|`` and ``|x2|`` over ``{x^T M x <= rho}``: ``sqrt(rho (M^-1)_ii)``.

    Both are inflated by :data:`BOUND_RTOL` for round-off; units follow ``x``.

    Parameters
    ----------
    m : ndarray, shape (2, 2)
        Symmetric positive definite form.
    rho : float
        Level; ``rho <= 0`` gives ``(0, 0)``.
    """
    m11, m12, m22 = float(m[0, 0]), float(m[0, 1]), float(m[1, 1])
    if rho <= 0.0:
        return 0.0, 0.0
    det = m11 * m22 - m12 * m12
    k = 1.0 + BOUND_RTOL
    return k * math.sqrt(rho * m22 / det), k * math.sqrt(rho * m11 / det)


def ellipsoid_extent(m: FloatArray, r1: float, r2: float) -> tuple[float, float]:
    """Sup of ``|x1|`` and ``|x2|`` over ``{x^T M x <= rho}``, rho the max over the start box.

    For ``M = M2`` (or ``M2 kron I2`` with ``x1, x2`` planar vectors) and the start set
    ``|x1| <= r1, |x2| <= r2``, ``rho`` is :func:`box_level` and the extents are
    :func:`level_extent` (inflated by :data:`BOUND_RTOL` for round-off). Units follow ``r1, r2``.

    Parameters
    ----------
    m : ndarray, shape (2, 2)
        Symmetric positive definite form ``M2``.
    r1, r2 : float
        Half-widths of the start box in ``x1`` and ``x2`` (norms for planar vectors).
    """
    return level_extent(m, box_level(m, r1, r2))


def pair_level(m: FloatArray, x: ArrayLike, dx: ArrayLike, planar: bool = False) -> FloatArray:
    """Level ``[x, x']^T (M kron I) [x, x']`` of error pairs in the ellipse of the (2, 2) ``m``.

    The planar products are written out, not reduced over the length-2 axis (cheaper in the
    hot path).

    Parameters
    ----------
    m : ndarray, shape (2, 2)
        Symmetric form.
    x, dx : array_like, shape (..., 2) or (...)
        Errors and their rates: inertial vectors (e.g. m and m/s) with ``planar``, otherwise
        scalars (e.g. rad and rad/s).
    planar : bool
        ``x`` and ``dx`` are planar vectors and the form is summed over both axes.
    """
    a, b = np.asarray(x, dtype=float), np.asarray(dx, dtype=float)
    if planar:
        a0, a1, b0, b1 = a[..., 0], a[..., 1], b[..., 0], b[..., 1]
        xx, xd, dd = a0 * a0 + a1 * a1, a0 * b0 + a1 * b1, b0 * b0 + b1 * b1
    else:
        xx, xd, dd = a * a, a * b, b * b
    out: FloatArray = m[0, 0] * xx + 2.0 * m[0, 1] * xd + m[1, 1] * dd
    return out


def start_bounds(
    p2: FloatArray, q: FloatArray, e0: ArrayLike, de0: ArrayLike, epsi0: ArrayLike, depsi0: ArrayLike
) -> FloatArray:
    """Per-start error bounds from actual initial errors, vectorised over starts.

    Parameters
    ----------
    p2, q : ndarray, shape (2, 2)
        Non-increasing Lyapunov matrices of the position and heading loops.
    e0, de0 : array_like, shape (..., 2)
        Initial position (m) and velocity (m/s) errors.
    epsi0, depsi0 : array_like, shape (...)
        Initial heading (rad) and yaw-rate (rad/s) errors.

    Returns
    -------
    ndarray, shape (..., 4)
        Bounds of ``sup_t ||e||, ||e'||, |e_psi|, |e_psi'|`` (m, m/s, rad, rad/s) with
        ``rho = x0^T P x0``.
    """
    rho_p, rho_q = pair_level(p2, e0, de0, planar=True), pair_level(q, epsi0, depsi0)
    ip, iq = np.linalg.inv(p2), np.linalg.inv(q)
    k = 1.0 + BOUND_RTOL
    rp, rq = np.maximum(rho_p, 0.0), np.maximum(rho_q, 0.0)
    out: FloatArray = k * np.sqrt(
        np.stack(np.broadcast_arrays(rp * ip[0, 0], rp * ip[1, 1], rq * iq[0, 0], rq * iq[1, 1]), -1)
    )
    return out


__all__ = ["BOUND_RTOL", "box_level", "ellipsoid_extent", "level_extent", "pair_level", "start_bounds"]
