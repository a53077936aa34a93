"""Lyapunov-Krasovskii LMIs of a second-order error loop driven by a lagged, held law.

Each per-vehicle error loop of the certificate is, on one axis, ``x = (e, e')`` with

    e'' = a e' + q + u + w,    u(t) = -k e(t - eta) - b e'(t - eta),    0 <= eta(t) <= tau,

where ``a`` ranges over a few vertices (heading: the yaw damping ``-d33(r)/m33``), ``q`` is a
norm-bounded uncertainty ``|q| <= sigma |e'|`` (position: ``D(t) e'``), ``w`` a bounded
disturbance, and ``eta`` the age of the measurement behind the held command (sample-and-hold
plus delay, :class:`~auv_hinf.models.implementation.Implementation`). With
``delta = x(t) - x(t - eta) = int_{t-eta}^t x'`` the law is ``u = -K x + K delta``, so
``x' = Gamma zeta`` with ``zeta = (x, delta, q, w)`` and ``Gamma = [A - BK, BK, B, B]``.

The functional (Fridman, *Introduction to Time-Delay Systems*, 2014, sec. 3.5 and 7.1)

    V = x^T P x + int_{-tau}^0 int_{t+theta}^t exp(2 beta (s - t)) x'(s)^T R x'(s) ds dtheta

satisfies, by Jensen's inequality over ``[t - eta, t]`` (``eta <= tau``),

    V' + 2 beta V - g |w|^2 <= zeta^T [He(E0^T P Gamma) + 2 beta E0^T P E0
                                 - exp(-2 beta tau)/tau Ed^T R Ed + tau Gamma^T R Gamma
                                 + mu (sigma^2 Fv^T Fv - Eq^T Eq) - g Ew^T Ew] zeta,

and the bracket is ``<= 0`` iff (Schur complement, ``R > 0``) the matrix :func:`lag_lmi_matrices`
builds is; it is affine in ``a``, so the vertices suffice. Then ``V`` decays like
``exp(-2 beta t)`` down to ``g |w|^2/(2 beta)``. With the measurement history taken only
from ``t >= 0`` (``eta(t) <= t``) the double integral starts at zero: ``V(0) = x(0)^T P x(0)``.
Every LMI holds on each axis separately and on the sum over the two horizontal axes
(``|q|^2 <= sigma^2 |e'|^2`` constrains the sum), so the scalar form certifies the planar loop.
Every returned answer is re-verified with ``eigvalsh`` (:func:`strict_nsd_gap`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.design.lmi.core import solve
from auv_hinf.design.lmi.lyapunov import LYAP_STRICT_RTOL, strict_nsd_gap
from auv_hinf.exceptions import DesignError, SolverError

_CP: Any = cp
_B = np.array([[0.0], [1.0]])
#: Largest number of damping vertices one cached SDP takes.
MAX_VERTICES = 2


@dataclass(frozen=True)
class LagLoop:
    """One axis of an error loop under a lagged law (see the module docstring).

    Attributes
    ----------
    dampings : tuple of float
        Vertices of the velocity coefficient ``a`` (1/s), one or two.
    k, b : float
        Feedback gains on ``e`` (1/s^2) and ``e'`` (1/s).
    sigma : float
        Bound of ``|q| / |e'|`` (1/s); 0 for no norm-bounded uncertainty.
    """

    dampings: tuple[float, ...]
    k: float
    b: float
    sigma: float = 0.0

    def __post_init__(self) -> None:
        vals = (*self.dampings, self.k, self.b, self.sigma)
        if not (1 <= len(self.dampings) <= MAX_VERTICES) or not all(math.isfinite(v) for v in vals):
            raise DesignError(f"a lag loop needs 1-{MAX_VERTICES} finite dampings and finite gains, got {self!r}")
        if self.sigma < 0:
            raise DesignError(f"sigma must be >= 0 (1/s), got {self.sigma!r}")

    def gamma_matrix(self, a: float) -> FloatArray:
        """``Gamma = [A - BK, BK, B, B]`` of vertex ``a``, shape ``(2, 6)`` (columns x, delta, q, w)."""
        bk = _B @ np.array([[self.k, self.b]])
        return np.hstack([np.array([[0.0, 1.0], [0.0, a]]) - bk, bk, _B, _B])


@dataclass(frozen=True)
class LagResult:
    """A verified Lyapunov-Krasovskii certificate of a :class:`LagLoop`.

    Attributes
    ----------
    p, r : ndarray, shape (2, 2)
        ``P > 0`` (the bound ``x^T P x <= V``) and ``R >= 0``.
    multiplier : float
        S-procedure multiplier ``mu``.
    gain : float
        ISS gain ``g`` (``V' <= -2 beta V + g |w|^2``); 0 when not requested.
    tau, beta : float
        Lag bound (s) and decay rate (1/s) it was verified at.
    max_eig, margin : float
        Largest eigenvalue of the verified matrices and the round-off margin it cleared.
    """

    p: FloatArray
    r: FloatArray
    multiplier: float
    gain: float
    tau: float
    beta: float
    max_eig: float
    margin: float


def _columns(tau: float, uncertain: bool, gain: bool) -> list[int]:
    """Columns of ``zeta = (x1, x2, d1, d2, q, w)`` in use: no ``delta`` without lag, no ``q``
    without uncertainty (``sigma = 0``), no ``w`` without gain."""
    return [0, 1] + ([2, 3] if tau > 0 else []) + ([4] if uncertain else []) + ([5] if gain else [])


def lag_lmi_matrices(
    loop: LagLoop, p: FloatArray, r: FloatArray, mu: float, g: float, tau: float, beta: float, gain: bool
) -> list[tuple[FloatArray, float]]:
    """The numeric LMI matrix of every vertex and the scale of its terms (for the eigenvalue re-check)."""
    cols = _columns(tau, loop.sigma > 0, gain)
    out = []
    for a in loop.dampings:
        gam = loop.gamma_matrix(a)[:, cols]
        nz = len(cols)
        e0 = np.eye(2, 6)[:, cols]
        ed = np.eye(2, 6, 2)[:, cols]
        eq = np.eye(1, 6, 4)[:, cols]
        ew = np.eye(1, 6, 5)[:, cols]
        fv = np.eye(1, 6, 1)[:, cols]
        pg = e0.T @ p @ gam
        xi = pg + pg.T + 2.0 * beta * e0.T @ p @ e0 + mu * (loop.sigma**2 * fv.T @ fv - eq.T @ eq)
        if gain:
            xi = xi - g * ew.T @ ew
        if tau > 0:
            xi = xi - math.exp(-2.0 * beta * tau) / tau * ed.T @ r @ ed
            rg = tau * r @ gam
            mat = np.block([[xi, rg.T], [rg, -tau * r]])
        else:
            mat = xi
        terms = [np.abs(pg).max(), abs(beta) * np.abs(p).max(), mu * (loop.sigma**2 + 1.0), g]
        if tau > 0:
            terms += [np.abs(r).max() / tau, np.abs(rg).max(), tau * np.abs(r).max()]
        out.append((0.5 * (mat + mat.T), 4.0 * float(max(terms)) * max(nz, 1)))
    return out


@lru_cache(maxsize=16)
def _problem(vertices: int, lagged: bool, uncertain: bool, gain: bool) -> tuple[cp.Problem, dict[str, Any], dict[str, Any]]:
    """The SDP for a loop shape; parameters are set per call (DPP: compiled once per shape).

    Without ``gain``: minimise ``s`` with every vertex matrix ``<= s I`` and
    ``trace P + trace R + mu = 1`` (always feasible; strictly feasible LMI iff ``s < 0``).
    With ``gain``: minimise ``g`` with the matrices ``<= -LYAP_STRICT_RTOL trace(P) I`` and
    ``P >= W`` (the weight ``W`` fixes the scale of ``P``).
    """
    tau = 1.0 if lagged else 0.0
    cols = _columns(tau, uncertain, gain)
    nz = len(cols)
    p = cp.Variable((2, 2), symmetric=True)
    r = cp.Variable((2, 2), symmetric=True)
    mu = cp.Variable(nonneg=True)
    g = cp.Variable(nonneg=True)
    s = cp.Variable()
    par: dict[str, Any] = {
        "beta2": cp.Parameter(nonneg=True),
        "jensen": cp.Parameter(nonneg=True),
        "tau": cp.Parameter(nonneg=True),
        "sig2": cp.Parameter(nonneg=True),
        "weight": cp.Parameter((2, 2), PSD=True),
        "gam": [cp.Parameter((2, nz)) for _ in range(vertices)],
        "tgam": [cp.Parameter((2, nz)) for _ in range(vertices)],
    }
    e0, ed = np.eye(2, 6)[:, cols], np.eye(2, 6, 2)[:, cols]
    eq, ew, fv = np.eye(1, 6, 4)[:, cols], np.eye(1, 6, 5)[:, cols], np.eye(1, 6, 1)[:, cols]
    size = nz + (2 if lagged else 0)
    cons: list[Any] = [p >> 0, r >> 0]
    for gam, tgam in zip(par["gam"], par["tgam"], strict=True):
        pg = e0.T @ p @ gam
        xi = pg + pg.T + par["beta2"] * (e0.T @ p @ e0)
        if uncertain:
            xi = xi + par["sig2"] * mu * (fv.T @ fv) - mu * (eq.T @ eq)
        if gain:
            xi = xi - g * (ew.T @ ew)
        if lagged:
            xi = xi - par["jensen"] * (ed.T @ r @ ed)
            rg = r @ tgam
            mat = _CP.bmat([[xi, rg.T], [rg, -par["tau"] * r]])
        else:
            mat = xi
        mat = 0.5 * (mat + mat.T)
        if gain:
            cons.append(mat << -LYAP_STRICT_RTOL * _CP.trace(p) * np.eye(size))
        else:
            cons.append(mat << s * np.eye(size))
    if gain:
        cons.append(p >> par["weight"])
        problem = cp.Problem(cp.Minimize(g), cons)
    else:
        cons.append(_CP.trace(p) + _CP.trace(r) + (mu if uncertain else 0.0) == 1)
        problem = cp.Problem(cp.Minimize(s), cons)
    return problem, par, {"p": p, "r": r, "mu": mu, "g": g}


def lmi_lag(loop: LagLoop, tau: float, beta: float, *, weight: FloatArray | None = None) -> LagResult | None:
    """Verified certificate of ``loop`` for every lag in ``[0, tau]`` at decay ``beta``, or ``None``.

    Parameters
    ----------
    loop : LagLoop
    tau : float
        Lag bound (s), ``>= 0``.
    beta : float
        Decay rate (1/s), ``>= 0``.
    weight : ndarray, shape (2, 2), optional
        When given, also minimise the ISS gain ``g`` with ``P >= weight`` (units of ``P``:
        ``1/m^2``-like, whatever scale the caller's bounds use).

    Returns
    -------
    LagResult or None
        ``None`` when the LMI is not strictly feasible or the eigenvalue re-check fails.

    Raises
    ------
    SolverError
        When Clarabel does not reach ``optimal`` (never cvxpy's own error).
    """
    if not (tau >= 0 and beta >= 0 and math.isfinite(tau) and math.isfinite(beta)):
        raise DesignError(f"need finite tau >= 0 (s) and beta >= 0 (1/s), got {tau!r}, {beta!r}")
    gain = weight is not None
    problem, par, var = _problem(len(loop.dampings), tau > 0, loop.sigma > 0, gain)
    par["beta2"].value = 2.0 * beta
    par["jensen"].value = math.exp(-2.0 * beta * tau) / tau if tau > 0 else 0.0
    par["tau"].value = tau
    par["sig2"].value = loop.sigma**2
    par["weight"].value = np.eye(2) if weight is None else np.asarray(weight, dtype=float)
    cols = _columns(tau, loop.sigma > 0, gain)
    for a, gp, tp in zip(loop.dampings, par["gam"], par["tgam"], strict=False):
        gam = loop.gamma_matrix(a)[:, cols]
        gp.value, tp.value = gam, tau * gam
    try:
        solve(problem, "lagged-loop Lyapunov-Krasovskii LMI")
    except SolverError:
        if gain:
            return None  # infeasible gain problem: Clarabel reports it as not optimal
        raise
    p = np.asarray(var["p"].value, dtype=float)
    r = np.asarray(var["r"].value, dtype=float)
    p, r = 0.5 * (p + p.T), 0.5 * (r + r.T)
    mu = max(float(np.asarray(var["mu"].value)), 0.0) if loop.sigma > 0 else 0.0
    g = max(float(np.asarray(var["g"].value)), 0.0) if gain else 0.0
    if gain:
        g *= 1.0 + 1e-9  # a hair above the optimum, so the re-check sees the strict inequality
    top, margin = -math.inf, 0.0
    for mat, scale in lag_lmi_matrices(loop, p, r, mu, g, tau, beta, gain):
        t, m = strict_nsd_gap(mat, scale)
        if t >= -m:
            return None
        top, margin = max(top, t), m if t >= top else margin
    if strict_nsd_gap(-p)[0] >= 0 or (tau > 0 and np.linalg.eigvalsh(r).min() < 0):
        return None
    return LagResult(p=p, r=r, multiplier=mu, gain=g, tau=tau, beta=beta, max_eig=top, margin=margin)


__all__ = ["MAX_VERTICES", "LagLoop", "LagResult", "lag_lmi_matrices", "lmi_lag"]
