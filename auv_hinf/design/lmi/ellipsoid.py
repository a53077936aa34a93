"""Invariant-ellipsoid LMIs of the perturbed error loops (robust certificate).

Both loops are 2-state (the position loop acts on ``(e, e')`` through ``P kron I2``) with a
unit-bounded disturbance ``|d| <= 1``; the real bound scales the ellipsoid linearly. A matrix
``P > 0`` with ``V' <= -a (V - 1)`` for every admissible uncertainty makes ``{V <= l}``
invariant for every ``l >= 1`` and gives ``V(t) - 1 <= (V(0) - 1) exp(-a t)``.

* position: ``x' = A0 x + b (w1 + w2 + d)`` with ``|w1| <= sigma |x2|`` and
  ``|w2| <= delta |k1 x1 + alpha x2|`` (S-procedure, multipliers ``tau1, tau2``);
* heading: ``x' = A(K, C) x + b d`` for every ``(K, C)`` in a box; ``A`` is affine in
  ``(K, C)``, so the LMI at the four vertices holds on the whole box and for time-varying
  ``K(t), C(t)``.

For a fixed rate ``a`` the SDP minimises ``ext_1^2 + w ext_2^2`` (the squared half-widths of
the ellipsoid along the two states, through Schur complements); :func:`best_ellipsoid`
searches ``a``. Every answer is re-verified with ``eigvalsh`` beyond a round-off margin.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.design.lmi.core import solve
from auv_hinf.design.lmi.lyapunov import LYAP_STRICT_RTOL, strict_nsd_gap
from auv_hinf.exceptions import SolverError

_CP: Any = cp
_B = np.array([[0.0], [1.0]])
#: Rates tried by the coarse search, as fractions of the nominal loop's largest admissible rate.
RATE_GRID = tuple(float(x) for x in np.geomspace(1e-3, 0.98, 10))
#: Golden-section refinements of the rate after the coarse grid.
RATE_REFINEMENTS = 5


@dataclass(frozen=True)
class Ellipsoid:
    """A verified invariant ellipsoid ``{x^T P x <= 1}`` of a unit-disturbance loop.

    Attributes
    ----------
    matrix : ndarray, shape (2, 2)
        ``P`` (positive definite).
    rate : float
        ``a`` (1/s): ``V - 1`` decays at least as ``exp(-a t)``.
    extents : tuple of float
        Half-widths of the last two states (``e``, ``e'``; m and m/s per unit disturbance):
        ``sqrt((P^-1)_kk)``.
    max_eig, margin : float
        Largest eigenvalue of the verified LMI matrices and the round-off margin it cleared.
    integral_extent : float
        Half-width of the integrator state ``z`` (m s per unit disturbance; 0 without one).
    """

    matrix: FloatArray
    rate: float
    extents: tuple[float, float]
    max_eig: float
    margin: float
    integral_extent: float = 0.0


def _sym(m: Any) -> Any:
    return 0.5 * (m + m.T)


def _unit(n: int, k: int) -> FloatArray:
    e = np.zeros((n, 1))
    e[k, 0] = 1.0
    return e


def _schur(p: cp.Variable, t: cp.Variable, k: int) -> cp.Constraint:
    e = _unit(p.shape[0], k)
    return _sym(_CP.bmat([[p, e], [e.T, _CP.reshape(t, (1, 1), order="C")]])) >> 0


@lru_cache(maxsize=3)
def _position_sdp(
    n: int, capped: bool
) -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable, tuple[cp.Variable, cp.Variable]]:
    """The position SDP on ``n`` states: ``(e, e')`` (n = 2) or ``(z, e, e')`` with integral action (n = 3).

    ``capped``: with a parameter ``cap`` bounding ``P_11`` (the integrator's start, see
    :func:`position_ellipsoid`).
    """
    a0, s1, s2 = cp.Parameter((n, n)), cp.Parameter((n, n), PSD=True), cp.Parameter((n, n), PSD=True)
    rate, weight = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    p = cp.Variable((n, n), symmetric=True)
    t1, t2 = cp.Variable(nonneg=True), cp.Variable(nonneg=True)
    te, tv = cp.Variable(), cp.Variable()
    pb = p @ _unit(n, n - 1)
    z = np.zeros((1, 1))
    top = a0.T @ p + p @ a0 + rate * p + t1 * s1 + t2 * s2
    m = _CP.bmat(
        [
            [top, pb, pb, pb],
            [pb.T, -_CP.reshape(t1, (1, 1), order="C"), z, z],
            [pb.T, z, -_CP.reshape(t2, (1, 1), order="C"), z],
            [pb.T, z, z, -_CP.reshape(rate, (1, 1), order="C")],
        ]
    )
    cons = [
        _sym(m) << -LYAP_STRICT_RTOL * _CP.trace(p) * np.eye(n + 3),
        p >> 0,
        _schur(p, te, n - 2),
        _schur(p, tv, n - 1),
    ]
    par: dict[str, cp.Parameter] = {"a0": a0, "s1": s1, "s2": s2, "rate": rate, "weight": weight}
    if capped:
        # the start: the integrator begins at z = 0, i.e. z~ = -z* off the equilibrium, which must
        # lie in {V <= d^2}: P_zz |z*|^2 <= d^2 (the caller gives cap = (d_min / |z*|_max)^2)
        par["cap"] = cp.Parameter(nonneg=True)
        cons.append(p[0, 0] <= par["cap"])
    prob = cp.Problem(cp.Minimize(te + weight * tv), cons)
    return prob, par, p, (t1, t2)


def position_matrix(
    p: FloatArray, taus: tuple[float, float], a0: FloatArray, s1: FloatArray, s2: FloatArray, rate: float
) -> FloatArray:
    """The ``(n + 3) x (n + 3)`` position LMI matrix (numpy), for the re-verification."""
    n = p.shape[0]
    pb = p @ _unit(n, n - 1)
    m = np.zeros((n + 3, n + 3))
    m[:n, :n] = a0.T @ p + p @ a0 + rate * p + taus[0] * s1 + taus[1] * s2
    for k in (n, n + 1, n + 2):
        m[:n, k : k + 1] = pb
        m[k : k + 1, :n] = pb.T
    m[n, n], m[n + 1, n + 1], m[n + 2, n + 2] = -taus[0], -taus[1], -rate
    return m


def _ellipsoid(p: FloatArray, rate: float, mats: list[FloatArray]) -> Ellipsoid | None:
    top, margin = -math.inf, 0.0
    for mat in mats:
        t, m = strict_nsd_gap(mat)
        if t >= -m:
            return None
        if t > top:
            top, margin = t, m
    t, m = strict_nsd_gap(-p)
    if t >= -m:
        return None
    half = np.sqrt(np.maximum(np.diag(np.linalg.inv(p)), 0.0))
    n = p.shape[0]
    ext = (float(half[n - 2]), float(half[n - 1]))
    return Ellipsoid(p, rate, ext, top, margin, float(half[0]) if n == 3 else 0.0)


def position_ellipsoid(
    a0: FloatArray,
    sigma: float,
    delta: float,
    c2: FloatArray,
    rate: float,
    weight: float,
    start_cap: float | None = None,
) -> Ellipsoid | None:
    """Invariant ellipsoid of the position loop at rate ``rate``; ``None`` if none is verified.

    Without integral action ``a0 = [[0, 1], [-l k1, lam - l alpha]]`` and ``c2 = [k1, alpha]``;
    with it the state is ``(z, e, e')``, ``a0 = [[0, 1, 0], [0, 0, 1], [-l ki, -l k1, lam - l alpha]]``,
    ``c2 = [ki, k1, alpha]`` and ``start_cap`` bounds ``P_zz`` (the start of the integrator,
    see :func:`_position_sdp`). ``sigma`` bounds ``||D||`` (acting on ``e'``) and ``delta`` the
    spread of the input gain ``L`` about its centre ``l``.
    """
    n = a0.shape[0]
    prob, par, p, (t1, t2) = _position_sdp(n, start_cap is not None)
    s1 = sigma**2 * _unit(n, n - 1) @ _unit(n, n - 1).T
    c = np.asarray(c2, dtype=float).reshape(1, n)
    s2 = delta**2 * (c.T @ c)
    par["a0"].value, par["s1"].value, par["s2"].value = a0, s1, 0.5 * (s2 + s2.T)
    par["rate"].value, par["weight"].value = rate, weight
    if start_cap is not None:
        par["cap"].value = start_cap
    try:
        solve(prob, "robust position-loop ellipsoid LMI")
    except SolverError:
        return None
    pv = np.asarray(p.value, dtype=float)
    pv = 0.5 * (pv + pv.T)
    if start_cap is not None and pv[0, 0] > start_cap:
        return None  # the solver's tolerance let the start slip out: not certified
    taus = (float(t1.value), float(t2.value))
    return _ellipsoid(pv, rate, [position_matrix(pv, taus, a0, s1, s2, rate)])


@lru_cache(maxsize=1)
def _heading_sdp() -> tuple[cp.Problem, dict[str, Any], cp.Variable]:
    verts = [cp.Parameter((2, 2)) for _ in range(4)]
    rate, weight = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    q = cp.Variable((2, 2), symmetric=True)
    te, tv = cp.Variable(), cp.Variable()
    qb = q @ _B
    cons = [
        _sym(_CP.bmat([[a.T @ q + q @ a + rate * q, qb], [qb.T, -_CP.reshape(rate, (1, 1), order="C")]]))
        << -LYAP_STRICT_RTOL * _CP.trace(q) * np.eye(3)
        for a in verts
    ]
    cons += [q >> 0, _schur(q, te, 0), _schur(q, tv, 1)]
    prob = cp.Problem(cp.Minimize(te + weight * tv), cons)
    return prob, {"verts": verts, "rate": rate, "weight": weight}, q


def heading_matrix(q: FloatArray, a: FloatArray, rate: float) -> FloatArray:
    """The 3x3 heading LMI matrix at one vertex (numpy), for the re-verification."""
    m = np.zeros((3, 3))
    m[:2, :2] = a.T @ q + q @ a + rate * q
    m[:2, 2:] = q @ _B
    m[2:, :2] = (q @ _B).T
    m[2, 2] = -rate
    return m


def heading_vertices(stiffness: tuple[float, float], damping: tuple[float, float]) -> list[FloatArray]:
    """``A = [[0, 1], [-K, -C]]`` at the four corners of the ``(K, C)`` box."""
    return [np.array([[0.0, 1.0], [-k, -c]]) for k in stiffness for c in damping]


def heading_ellipsoid(
    stiffness: tuple[float, float], damping: tuple[float, float], rate: float, weight: float
) -> Ellipsoid | None:
    """Invariant ellipsoid of the heading loop for every ``K(t), C(t)`` in the box; ``None`` if none."""
    prob, par, q = _heading_sdp()
    verts = heading_vertices(stiffness, damping)
    for p_, a in zip(par["verts"], verts):
        p_.value = a
    par["rate"].value, par["weight"].value = rate, weight
    try:
        solve(prob, "robust heading-loop ellipsoid LMI")
    except SolverError:
        return None
    qv = np.asarray(q.value, dtype=float)
    qv = 0.5 * (qv + qv.T)
    return _ellipsoid(qv, rate, [heading_matrix(qv, a, rate) for a in verts])


def best_ellipsoid(build: Callable[[float], Ellipsoid | None], rate_max: float, weight: float) -> Ellipsoid | None:
    """The verified ellipsoid of smallest ``ext_1^2 + weight ext_2^2`` over the rate.

    Coarse search over :data:`RATE_GRID` times ``rate_max``, then golden-section refinement
    (in ``log a``) between the neighbours of the best rate. Any verified ellipsoid is sound;
    the search only makes it small.
    """

    def score(e: Ellipsoid | None) -> float:
        return math.inf if e is None else e.extents[0] ** 2 + weight * e.extents[1] ** 2

    rates = [f * rate_max for f in RATE_GRID]
    found = [build(a) for a in rates]
    k = int(np.argmin([score(e) for e in found]))
    best = found[k]
    if best is None:
        return None
    lo = math.log(rates[max(k - 1, 0)])
    hi = math.log(rates[min(k + 1, len(rates) - 1)])
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(RATE_REFINEMENTS):
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        e1, e2 = build(math.exp(x1)), build(math.exp(x2))
        for e in (e1, e2):
            if score(e) < score(best):
                best = e
        if score(e1) <= score(e2):
            hi = x2
        else:
            lo = x1
    return best


__all__ = [
    "RATE_GRID",
    "RATE_REFINEMENTS",
    "Ellipsoid",
    "best_ellipsoid",
    "heading_ellipsoid",
    "heading_matrix",
    "heading_vertices",
    "position_ellipsoid",
    "position_matrix",
]
