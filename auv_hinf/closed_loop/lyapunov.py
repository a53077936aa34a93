"""Lyapunov LMIs of the closed-loop error loops: decay rates and invariant regions."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import SolverError
from auv_hinf.numerics.lmi import LYAP_STRICT_RTOL, solve, strict_nsd_gap

# --------------------------------------------------------------------------------------
# Closed-loop Lyapunov LMIs (position and heading error loops), used by ``closed_loop`` and
# ``region``. Every returned matrix is re-verified with ``numpy.linalg.eigvalsh`` against a
# strict round-off margin (:func:`strict_nsd_gap`).
# --------------------------------------------------------------------------------------


#: cvxpy's top-level names (bmat, trace, reshape) are implicit re-exports, which strict mypy
#: does not see; they are reached through this ``Any`` alias.
_CP: Any = cp

_E1 = np.array([[1.0, 0.0]])
_E2 = np.array([[0.0, 1.0]])


def position_lmi_matrix(
    p2: FloatArray, tau: float, lam: float, alpha: float, k1: float, sigma: float, beta: float
) -> tuple[FloatArray, float]:
    """Numeric position-loop LMI matrix and the scale of its terms.

    ``[[a^T P2 + P2 a + 2 beta P2 + tau sigma^2 c^T c, P2 b], [b^T P2, -tau]]`` with
    ``a = [[0, 1], [-k1, lam - alpha]]``, ``b = [0, 1]^T``, ``c = [0, 1]`` (units: P2 is
    dimensionless up to a common scale, the entries are 1/s times that scale).

    Parameters
    ----------
    p2 : ndarray, shape (2, 2)
        Candidate Lyapunov matrix ``P2``.
    tau : float
        S-procedure multiplier, >= 0.
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    sigma : float
        Bound of ``||D(t)||`` (1/s).
    beta : float
        Decay rate (1/s).
    """
    a = np.array([[0.0, 1.0], [-k1, lam - alpha]])
    pa = a.T @ p2
    top = pa + pa.T + 2.0 * beta * p2 + tau * sigma * sigma * (_E2.T @ _E2)
    pb = p2 @ _E2.T
    mat = np.block([[top, pb], [pb.T, -tau * np.ones((1, 1))]])
    pn = float(np.abs(p2).max())
    scale = (4.0 * float(np.abs(a).max()) + 2.0 * abs(beta) + 1.0) * pn + tau * (sigma * sigma + 1.0)
    return mat, scale


def heading_lmi_matrices(
    q: FloatArray, k1psi: float, c_range: tuple[float, float], beta: float
) -> list[tuple[FloatArray, float]]:
    """Numeric ``A(c)^T Q + Q A(c) + 2 beta Q`` at ``c = c_lo, c_hi`` with term scales.

    ``A(c) = [[0, 1], [-k1psi, -c]]``.

    Parameters
    ----------
    q : ndarray, shape (2, 2)
        Candidate Lyapunov matrix ``Q``.
    k1psi : float
        Heading position gain (1/s^2).
    c_range : tuple of float
        ``(c_lo, c_hi)``, range of the heading damping ``c`` (1/s).
    beta : float
        Decay rate (1/s).
    """
    out = []
    for c in c_range:
        a = np.array([[0.0, 1.0], [-k1psi, -c]])
        qa = a.T @ q
        qn = float(np.abs(q).max())
        out.append((qa + qa.T + 2.0 * beta * q, (4.0 * float(np.abs(a).max()) + 2.0 * abs(beta)) * qn))
    return out


@dataclass(frozen=True)
class LyapunovResult:
    """A verified quadratic Lyapunov matrix of a 2-state error loop.

    Attributes
    ----------
    matrix : ndarray, shape (2, 2)
        ``P2`` (position loop, acting on ``(e, e')`` as ``P2 kron I2``) or ``Q`` (heading
        loop, on ``(e_psi, e_psi')``); positive definite.
    multiplier : float
        S-procedure multiplier tau of the position LMI (0 for the heading loop).
    beta : float
        Decay rate the LMI was verified at (1/s).
    max_eig : float
        Largest eigenvalue of the (largest) verified LMI matrix; below ``-margin``.
    margin : float
        Round-off margin it cleared (:func:`roundoff_margin`).
    objective : float
        Optimal value of the SDP solved (its meaning depends on the SDP).
    """

    matrix: FloatArray
    multiplier: float
    beta: float
    max_eig: float
    margin: float
    objective: float


def _verify_lyapunov(
    what: str,
    matrix: FloatArray,
    mats: list[tuple[FloatArray, float]],
    tau: float,
    beta: float,
    objective: float,
) -> LyapunovResult | None:
    """Re-check strict negativity of every LMI matrix and ``matrix > 0``; None if it fails."""
    top, margin = -math.inf, 0.0
    for mat, scale in mats:
        t, m = strict_nsd_gap(mat, scale)
        if t >= -m:
            return None
        if t > top:
            top, margin = t, m
    t, m = strict_nsd_gap(-matrix)
    if t >= -m:
        return None
    return LyapunovResult(matrix=matrix, multiplier=tau, beta=beta, max_eig=top, margin=margin, objective=objective)


def _sym(mat: Any) -> Any:
    return 0.5 * (mat + mat.T)


def _value(problem: cp.Problem) -> float:
    """Optimal value of a solved problem as a float."""
    return float(np.asarray(problem.value, dtype=float))


@lru_cache(maxsize=1)
def _position_gevp() -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable, cp.Variable]:
    """Minimise s with ``LMI(P2, tau, beta) <= s I``, ``trace(P2) + tau = 1``, ``P2 >= 0``."""
    a = cp.Parameter((2, 2))
    sig2 = cp.Parameter(nonneg=True)
    beta = cp.Parameter(nonneg=True)
    p = cp.Variable((2, 2), symmetric=True)
    tau = cp.Variable(nonneg=True)
    s = cp.Variable()
    top = a.T @ p + p @ a + 2.0 * beta * p + tau * sig2 * (_E2.T @ _E2)
    mat = _CP.bmat([[top, p @ _E2.T], [_E2 @ p, -_CP.reshape(tau, (1, 1), order="C")]])
    problem = cp.Problem(cp.Minimize(s), [_sym(mat) << s * np.eye(3), _CP.trace(p) + tau == 1, p >> 0])
    return problem, {"a": a, "sig2": sig2, "beta": beta}, p, tau


def lmi_position_lyapunov(lam: float, alpha: float, k1: float, sigma: float, beta: float) -> LyapunovResult | None:
    """Common quadratic Lyapunov function ``P2 kron I2`` of the position loop at decay ``beta``.

    The loop is ``x' = (a kron I2) x + (b kron I2) w``, ``z = (c kron I2) x``, ``w = D z``
    with ``||D(t)|| <= sigma``, ``x = (e, e')``. Both the nominal matrices and the set
    ``{||D|| <= sigma}`` are invariant under ``x -> (I2 kron U) x``, ``D -> U D U^T`` for
    every ``U`` in O(2); the LMI is linear in P, so averaging a feasible 4x4 P over O(2)
    (Haar measure) gives a feasible P that commutes with ``I2 kron U`` for all U, i.e.
    ``P2 kron I2``. Restricting to that form therefore loses nothing.
    By the S-procedure (lossless for one quadratic constraint) the LMI
    ``[[a^T P2 + P2 a + 2 beta P2 + tau sigma^2 c^T c, P2 b], [b^T P2, -tau]] <= 0``
    makes ``V = x^T (P2 kron I2) x`` decay as ``exp(-2 beta t)`` for every such ``D(t)``.

    Solves the generalized-eigenvalue form (minimise the largest eigenvalue ``s`` of the
    LMI over ``trace(P2) + tau = 1``; always feasible, so Clarabel must say ``optimal``)
    and returns the verified answer, or ``None`` when the LMI is not strictly feasible
    (``s >= 0``) or the strict re-check with ``eigvalsh`` fails.

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    sigma : float
        Bound of ``||D(t)||`` (1/s).
    beta : float
        Decay rate (1/s), >= 0.
    """
    problem, par, p, tau = _position_gevp()
    par["a"].value = np.array([[0.0, 1.0], [-k1, lam - alpha]])
    par["sig2"].value = sigma * sigma
    par["beta"].value = beta
    solve(problem, "position-loop Lyapunov LMI")
    p2 = np.asarray(p.value, dtype=float)
    p2 = 0.5 * (p2 + p2.T)
    t = max(float(np.asarray(tau.value, dtype=float)), 0.0)
    mat = position_lmi_matrix(p2, t, lam, alpha, k1, sigma, beta)
    return _verify_lyapunov("position LMI", p2, [mat], t, beta, _value(problem))


@lru_cache(maxsize=1)
def _heading_gevp() -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable]:
    """Minimise s with ``A(c)^T Q + Q A(c) + 2 beta Q <= s I`` at both vertices, ``trace Q = 1``."""
    a_lo, a_hi = cp.Parameter((2, 2)), cp.Parameter((2, 2))
    beta = cp.Parameter(nonneg=True)
    q = cp.Variable((2, 2), symmetric=True)
    s = cp.Variable()
    cons = [_sym(a.T @ q + q @ a + 2.0 * beta * q) << s * np.eye(2) for a in (a_lo, a_hi)]
    problem = cp.Problem(cp.Minimize(s), [*cons, _CP.trace(q) == 1, q >> 0])
    return problem, {"a_lo": a_lo, "a_hi": a_hi, "beta": beta}, q


def _heading_a(k1psi: float, c: float) -> FloatArray:
    return np.array([[0.0, 1.0], [-k1psi, -c]])


def lmi_heading_lyapunov(k1psi: float, c_range: tuple[float, float], beta: float) -> LyapunovResult | None:
    """Common ``Q`` of the heading loop for every time-varying ``c(t)`` in ``c_range``.

    ``A(c)`` is affine in ``c``, so the LMI at the two vertices holds on the whole interval
    and ``V = x^T Q x`` decays at ``2 beta`` for any ``c(t)`` in it. Returns ``None`` when
    not strictly feasible or when the ``eigvalsh`` re-check fails.

    Parameters
    ----------
    k1psi : float
        Heading position gain (1/s^2).
    c_range : tuple of float
        ``(c_lo, c_hi)``, range of the heading damping ``c`` (1/s).
    beta : float
        Decay rate (1/s), >= 0.
    """
    problem, par, q = _heading_gevp()
    par["a_lo"].value = _heading_a(k1psi, c_range[0])
    par["a_hi"].value = _heading_a(k1psi, c_range[1])
    par["beta"].value = beta
    solve(problem, "heading-loop Lyapunov LMI")
    qv = np.asarray(q.value, dtype=float)
    qv = 0.5 * (qv + qv.T)
    return _verify_lyapunov(
        "heading LMI", qv, heading_lmi_matrices(qv, k1psi, c_range, beta), 0.0, beta, _value(problem)
    )


def _start_constraints(m: cp.Variable, w: dict[str, cp.Parameter]) -> list[cp.Constraint]:
    """``m11 r1^2 +- 2 m12 r1 r2 + m22 r2^2 <= 1``: the box start set inside ``x^T M x <= 1``."""
    base = w["w11"] * m[0, 0] + w["w22"] * m[1, 1]
    return [base + w["w12"] * m[0, 1] <= 1, base - w["w12"] * m[0, 1] <= 1]


def _weights() -> dict[str, cp.Parameter]:
    return {k: cp.Parameter(nonneg=True) for k in ("w11", "w12", "w22")}


def _set_weights(w: dict[str, cp.Parameter], r1: float, r2: float) -> None:
    w["w11"].value, w["w12"].value, w["w22"].value = r1 * r1, 2.0 * r1 * r2, r2 * r2


@lru_cache(maxsize=1)
def _position_region_sdp() -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable, cp.Variable]:
    """Minimise ``t >= (P2^-1)_22`` over the start-set and homogeneous (beta = 0) LMIs."""
    a = cp.Parameter((2, 2))
    sig2 = cp.Parameter(nonneg=True)
    w = _weights()
    p = cp.Variable((2, 2), symmetric=True)
    tau = cp.Variable(nonneg=True)
    t = cp.Variable((1, 1))
    top = a.T @ p + p @ a + tau * sig2 * (_E2.T @ _E2)
    mat = _CP.bmat([[top, p @ _E2.T], [_E2 @ p, -_CP.reshape(tau, (1, 1), order="C")]])
    strict = LYAP_STRICT_RTOL * (_CP.trace(p) + tau)
    cons = [_sym(mat) << -strict * np.eye(3), _sym(_CP.bmat([[p, _E2.T], [_E2, t]])) >> 0]
    problem = cp.Problem(cp.Minimize(t[0, 0]), cons + _start_constraints(p, w))
    return problem, {"a": a, "sig2": sig2, **w}, p, tau


def lmi_position_region(lam: float, alpha: float, k1: float, sigma: float, rp: float, rv: float) -> LyapunovResult:
    """``P2`` of the smallest velocity extent whose invariant ellipsoid holds the start box.

    The start box is ``||e|| <= rp, ||e'|| <= rv``; the velocity extent is
    ``sqrt((P2^-1)_22)``, at level 1. Homogeneous LMI (``beta = 0``, tau free, strict by
    :data:`LYAP_STRICT_RTOL`).

    Parameters
    ----------
    lam : float
        Envelope lambda (1/s).
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    sigma : float
        Bound of ``||D(t)||`` (1/s).
    rp : float
        Position-error radius of the start box (m), >= 0.
    rv : float
        Velocity-error radius of the start box (m/s), >= 0; not both zero.

    Raises
    ------
    SolverError
        If Clarabel is not optimal or the strict ``eigvalsh`` re-check fails.
    """
    problem, par, p, tau = _position_region_sdp()
    par["a"].value = np.array([[0.0, 1.0], [-k1, lam - alpha]])
    par["sig2"].value = sigma * sigma
    _set_weights(par, rp, rv)
    solve(problem, "position-region SDP")
    p2 = np.asarray(p.value, dtype=float)
    p2 = 0.5 * (p2 + p2.T)
    t = max(float(np.asarray(tau.value, dtype=float)), 0.0)
    res = _verify_lyapunov(
        "position region", p2, [position_lmi_matrix(p2, t, lam, alpha, k1, sigma, 0.0)], t, 0.0, _value(problem)
    )
    if res is None:
        raise SolverError("position-region SDP: the returned P2 fails the strict eigvalsh re-check")
    return res


@lru_cache(maxsize=1)
def _heading_region_sdp() -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable]:
    """Minimise s with ``(Q^-1)_11 <= s b1``, ``(Q^-1)_22 <= s b2`` over start set and LMIs."""
    a_lo, a_hi = cp.Parameter((2, 2)), cp.Parameter((2, 2))
    b1, b2 = cp.Parameter(pos=True), cp.Parameter(pos=True)
    w = _weights()
    q = cp.Variable((2, 2), symmetric=True)
    s = cp.Variable()
    strict = LYAP_STRICT_RTOL * _CP.trace(q)
    cons = [_sym(a.T @ q + q @ a) << -strict * np.eye(2) for a in (a_lo, a_hi)]
    for e, b in ((_E1, b1), (_E2, b2)):
        cons.append(_sym(_CP.bmat([[q, e.T], [e, _CP.reshape(s * b, (1, 1), order="C")]])) >> 0)
    problem = cp.Problem(cp.Minimize(s), cons + _start_constraints(q, w))
    return problem, {"a_lo": a_lo, "a_hi": a_hi, "b1": b1, "b2": b2, **w}, q


def lmi_heading_region(
    k1psi: float, c_range: tuple[float, float], rh: float, rr: float, budgets: tuple[float, float]
) -> LyapunovResult:
    """``Q`` whose invariant ellipsoid through the start box best fits the heading budgets.

    The start box is ``|e_psi| <= rh, |e_psi'| <= rr``: minimise s with ``(Q^-1)_11 <= s B_psi^2``
    and ``(Q^-1)_22 <= s B_r^2`` (s <= 1 means both budgets are met). Homogeneous LMIs at the
    two vertices of ``c_range``, strict by :data:`LYAP_STRICT_RTOL`.

    Parameters
    ----------
    k1psi : float
        Heading position gain (1/s^2).
    c_range : tuple of float
        ``(c_lo, c_hi)``, range of the heading damping ``c`` (1/s).
    rh : float
        Heading-error radius of the start box (rad), >= 0.
    rr : float
        Yaw-rate-error radius of the start box (rad/s), >= 0.
    budgets : tuple of float
        ``(B_psi^2, B_r^2)`` (rad^2, rad^2/s^2), > 0.

    Raises
    ------
    SolverError
        If Clarabel is not optimal or the strict ``eigvalsh`` re-check fails.
    """
    problem, par, q = _heading_region_sdp()
    par["a_lo"].value = _heading_a(k1psi, c_range[0])
    par["a_hi"].value = _heading_a(k1psi, c_range[1])
    par["b1"].value, par["b2"].value = budgets
    _set_weights(par, rh, rr)
    solve(problem, "heading-region SDP")
    qv = np.asarray(q.value, dtype=float)
    qv = 0.5 * (qv + qv.T)
    res = _verify_lyapunov(
        "heading region", qv, heading_lmi_matrices(qv, k1psi, c_range, 0.0), 0.0, 0.0, _value(problem)
    )
    if res is None:
        raise SolverError("heading-region SDP: the returned Q fails the strict eigvalsh re-check")
    return res


__all__ = [
    "LyapunovResult",
    "heading_lmi_matrices",
    "lmi_heading_lyapunov",
    "lmi_heading_region",
    "lmi_position_lyapunov",
    "lmi_position_region",
    "position_lmi_matrix",
]
