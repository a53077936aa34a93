"""Lyapunov-Krasovskii LMIs of a second-order error loop driven by a lagged, held law.

Each per-vehicle error loop of the certificate is, on one axis, ``x = (e, e')`` with

    e'' = a e' + q + q2 + u + w,    u(t) = -k e(t - eta) - b e'(t - eta),    0 <= eta(t) <= tau,

where ``a`` ranges over a few vertices (heading: the yaw damping ``-d33(r)/m33``), ``q`` is a
norm-bounded uncertainty ``|q| <= sigma |e'|`` (position: ``D(t) e'``), ``w`` a bounded
disturbance, and ``eta`` the age of the measurement behind the held command (sample-and-hold
plus delay, :class:`~auv_hinf.implementation.model.Implementation`). With
``delta = x(t) - x(t - eta) = int_{t-eta}^t x'`` the law is ``u = -K x + K delta``; ``q2`` is a
second norm-bounded term ``|q2| <= sigma2 |delta_2|`` driven by the change of the velocity error
over the lag (position: the drift feedforward evaluated at the old state). So ``x' = Gamma zeta``
with ``zeta = (x, delta, q, q2, w)`` and ``Gamma = [A - BK, BK, B, B, B]``.

The functional (Fridman, *Introduction to Time-Delay Systems*, 2014, sec. 3.5 and 7.1)::

    V = x^T P x + int_{-tau}^0 int_{t+theta}^t exp(2 beta (s - t)) x'(s)^T R x'(s) ds dtheta

satisfies, by Jensen's inequality over ``[t - eta, t]`` (``eta <= tau``)::

    V' + 2 beta V - g |w|^2 <= zeta^T [He(E0^T P Gamma) + 2 beta E0^T P E0
                                 - exp(-2 beta tau)/tau Ed^T R Ed + tau Gamma^T R Gamma
                                 + mu (sigma^2 Fv^T Fv - Eq^T Eq)
                                 + mu2 (sigma2^2 Fd^T Fd - Eq2^T Eq2) - g Ew^T Ew] zeta,

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
from auv_hinf.exceptions import DesignError, SolverError
from auv_hinf.numerics.lmi import LYAP_STRICT_RTOL, solve, strict_nsd_gap

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
    lag_sigma : float
        Bound of ``|q2| / |delta_2|`` (1/s); 0 for none.
    """

    dampings: tuple[float, ...]
    k: float
    b: float
    sigma: float = 0.0
    lag_sigma: float = 0.0

    def __post_init__(self) -> None:
        vals = (*self.dampings, self.k, self.b, self.sigma, self.lag_sigma)
        if not (1 <= len(self.dampings) <= MAX_VERTICES) or not all(math.isfinite(v) for v in vals):
            raise DesignError(f"a lag loop needs 1-{MAX_VERTICES} finite dampings and finite gains, got {self!r}")
        if self.sigma < 0 or self.lag_sigma < 0:
            raise DesignError(f"sigma and lag_sigma must be >= 0 (1/s), got {self.sigma!r}, {self.lag_sigma!r}")

    def gamma_matrix(self, a: float) -> FloatArray:
        """``Gamma = [A - BK, BK, B, B, B]`` of vertex ``a``, shape ``(2, 7)`` (columns x, delta, q, q2, w).

        Parameters
        ----------
        a : float
            Vertex of the velocity coefficient (1/s), ``A = [[0, 1], [0, a]]``.
        """
        bk = _B @ np.array([[self.k, self.b]])
        return np.hstack([np.array([[0.0, 1.0], [0.0, a]]) - bk, bk, _B, _B, _B])


@dataclass(frozen=True)
class LagResult:
    """A verified Lyapunov-Krasovskii certificate of a :class:`LagLoop`.

    Attributes
    ----------
    p, r : ndarray, shape (2, 2)
        ``P > 0`` (the bound ``x^T P x <= V``) and ``R >= 0``.
    multiplier : float
        S-procedure multiplier ``mu`` (``mu2`` of the lag channel is in ``lag_multiplier``).
    gain : float
        ISS gain ``g`` (``V' <= -2 beta V + g |w|^2``); 0 when not requested.
    tau, beta : float
        Lag bound (s) and decay rate (1/s) it was verified at.
    max_eig, margin : float
        Largest eigenvalue of the verified matrices and the round-off margin it cleared.
    lag_multiplier : float
        S-procedure multiplier ``mu2`` of the lag channel (0 without one).
    """

    p: FloatArray
    r: FloatArray
    multiplier: float
    gain: float
    tau: float
    beta: float
    max_eig: float
    margin: float
    lag_multiplier: float = 0.0


#: Column of each part of ``zeta`` in the full layout.
_X, _D, _Q, _Q2, _W = (0, 1), (2, 3), 4, 5, 6
_FULL = 7


def _columns(tau: float, uncertain: bool, gain: bool, lag_uncertain: bool = False) -> list[int]:
    """Columns of ``zeta = (x1, x2, d1, d2, q, q2, w)`` in use: no ``delta`` (nor ``q2``) without
    lag, no ``q`` without uncertainty (``sigma = 0``), no ``q2`` without ``lag_sigma``, no ``w``
    without gain."""
    lagged = tau > 0
    return (
        list(_X)
        + (list(_D) if lagged else [])
        + ([_Q] if uncertain else [])
        + ([_Q2] if lagged and lag_uncertain else [])
        + ([_W] if gain else [])
    )


def _selectors(cols: list[int]) -> dict[str, FloatArray]:
    """Row selectors of ``zeta``'s parts restricted to ``cols``: ``e0`` (x), ``ed`` (delta),
    ``fv`` (e'), ``fd`` (delta_2), ``eq``, ``eq2``, ``ew``."""
    eye = np.eye(_FULL)[:, cols]
    return {
        "e0": eye[list(_X)],
        "ed": eye[list(_D)],
        "fv": eye[[_X[1]]],
        "fd": eye[[_D[1]]],
        "eq": eye[[_Q]],
        "eq2": eye[[_Q2]],
        "ew": eye[[_W]],
    }


def lag_lmi_matrices(
    loop: LagLoop,
    p: FloatArray,
    r: FloatArray,
    mu: float,
    g: float,
    tau: float,
    beta: float,
    gain: bool,
    mu2: float = 0.0,
) -> list[tuple[FloatArray, float]]:
    """The numeric LMI matrix of every vertex and the scale of its terms (for the eigenvalue re-check).

    Parameters
    ----------
    loop : LagLoop
        The loop (its dampings are the vertices).
    p, r : ndarray, shape (2, 2)
        The functional's matrices ``P`` and ``R``.
    mu : float
        S-procedure multiplier of ``q`` (unused when ``loop.sigma`` is 0).
    g : float
        ISS gain (used with ``gain`` only).
    tau : float
        Lag bound (s), >= 0; 0 drops the ``delta`` columns and the ``R`` terms.
    beta : float
        Decay rate (1/s).
    gain : bool
        Whether the ``w`` column and the ``- g Ew^T Ew`` term are included.
    mu2 : float
        S-procedure multiplier of ``q2`` (unused when ``loop.lag_sigma`` or ``tau`` is 0).
    """
    cols = _columns(tau, loop.sigma > 0, gain, loop.lag_sigma > 0)
    sel = _selectors(cols)
    e0, ed, fv, fd, eq, eq2, ew = (sel[k] for k in ("e0", "ed", "fv", "fd", "eq", "eq2", "ew"))
    out = []
    for a in loop.dampings:
        gam = loop.gamma_matrix(a)[:, cols]
        nz = len(cols)
        pg = e0.T @ p @ gam
        xi = pg + pg.T + 2.0 * beta * e0.T @ p @ e0 + mu * (loop.sigma**2 * fv.T @ fv - eq.T @ eq)
        xi = xi + mu2 * (loop.lag_sigma**2 * fd.T @ fd - eq2.T @ eq2)
        if gain:
            xi = xi - g * ew.T @ ew
        if tau > 0:
            xi = xi - math.exp(-2.0 * beta * tau) / tau * ed.T @ r @ ed
            rg = tau * r @ gam
            mat = np.block([[xi, rg.T], [rg, -tau * r]])
        else:
            mat = xi
        terms = [np.abs(pg).max(), abs(beta) * np.abs(p).max(), mu * (loop.sigma**2 + 1.0), g]
        terms.append(mu2 * (loop.lag_sigma**2 + 1.0))
        if tau > 0:
            terms += [np.abs(r).max() / tau, np.abs(rg).max(), tau * np.abs(r).max()]
        out.append((0.5 * (mat + mat.T), 4.0 * float(max(terms)) * max(nz, 1)))
    return out


@lru_cache(maxsize=16)
def _problem(
    vertices: int, lagged: bool, uncertain: bool, gain: bool, lag_uncertain: bool
) -> tuple[cp.Problem, dict[str, Any], dict[str, Any]]:
    """The SDP for a loop shape; parameters are set per call (DPP: compiled once per shape).

    Without ``gain``: minimise ``s`` with every vertex matrix ``<= s I`` and
    ``trace P + trace R + mu = 1`` (always feasible; strictly feasible LMI iff ``s < 0``).
    With ``gain``: minimise ``g`` with the matrices ``<= -LYAP_STRICT_RTOL trace(P) I`` and
    ``P >= W`` (the weight ``W`` fixes the scale of ``P``).
    """
    tau = 1.0 if lagged else 0.0
    cols = _columns(tau, uncertain, gain, lag_uncertain)
    lag_q = _Q2 in cols
    nz = len(cols)
    p = cp.Variable((2, 2), symmetric=True)
    r = cp.Variable((2, 2), symmetric=True)
    mu = cp.Variable(nonneg=True)
    mu2 = cp.Variable(nonneg=True)
    g = cp.Variable(nonneg=True)
    s = cp.Variable()
    par: dict[str, Any] = {
        "beta2": cp.Parameter(nonneg=True),
        "jensen": cp.Parameter(nonneg=True),
        "tau": cp.Parameter(nonneg=True),
        "sig2": cp.Parameter(nonneg=True),
        "lsig2": cp.Parameter(nonneg=True),
        "weight": cp.Parameter((2, 2), PSD=True),
        "gam": [cp.Parameter((2, nz)) for _ in range(vertices)],
        "tgam": [cp.Parameter((2, nz)) for _ in range(vertices)],
    }
    sel = _selectors(cols)
    e0, ed, fv, fd, eq, eq2, ew = (sel[k] for k in ("e0", "ed", "fv", "fd", "eq", "eq2", "ew"))
    size = nz + (2 if lagged else 0)
    cons: list[Any] = [p >> 0, r >> 0]
    for gam, tgam in zip(par["gam"], par["tgam"], strict=True):
        pg = e0.T @ p @ gam
        xi = pg + pg.T + par["beta2"] * (e0.T @ p @ e0)
        if uncertain:
            xi = xi + par["sig2"] * mu * (fv.T @ fv) - mu * (eq.T @ eq)
        if lag_q:
            xi = xi + par["lsig2"] * mu2 * (fd.T @ fd) - mu2 * (eq2.T @ eq2)
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
        cons.append(_CP.trace(p) + _CP.trace(r) + (mu if uncertain else 0.0) + (mu2 if lag_q else 0.0) == 1)
        problem = cp.Problem(cp.Minimize(s), cons)
    return problem, par, {"p": p, "r": r, "mu": mu, "mu2": mu2, "g": g}


def lmi_lag(loop: LagLoop, tau: float, beta: float, *, weight: FloatArray | None = None) -> LagResult | None:
    """Verified certificate of ``loop`` for every lag in ``[0, tau]`` at decay ``beta``, or ``None``.

    Clarabel's statuses other than ``optimal`` (after its retries) count as "not certified"
    (``None``); cvxpy's own errors never escape.

    Parameters
    ----------
    loop : LagLoop
        The loop to certify.
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
    """
    if not (tau >= 0 and beta >= 0 and math.isfinite(tau) and math.isfinite(beta)):
        raise DesignError(f"need finite tau >= 0 (s) and beta >= 0 (1/s), got {tau!r}, {beta!r}")
    gain = weight is not None
    lag_q = tau > 0 and loop.lag_sigma > 0
    problem, par, var = _problem(len(loop.dampings), tau > 0, loop.sigma > 0, gain, lag_q)
    par["beta2"].value = 2.0 * beta
    par["jensen"].value = math.exp(-2.0 * beta * tau) / tau if tau > 0 else 0.0
    par["tau"].value = tau
    par["sig2"].value = loop.sigma**2
    par["lsig2"].value = loop.lag_sigma**2
    par["weight"].value = np.eye(2) if weight is None else np.asarray(weight, dtype=float)
    cols = _columns(tau, loop.sigma > 0, gain, loop.lag_sigma > 0)
    for a, gp, tp in zip(loop.dampings, par["gam"], par["tgam"], strict=False):
        gam = loop.gamma_matrix(a)[:, cols]
        gp.value, tp.value = gam, tau * gam
    try:
        solve(problem, "lagged-loop Lyapunov-Krasovskii LMI")
    except SolverError:
        # an infeasible gain problem, or a numerically hopeless one (e.g. a lag far below the
        # loop's time constants, where 1/tau dominates): nothing is certified at this point,
        # which the callers treat as infeasible (conservative)
        return None
    p = np.asarray(var["p"].value, dtype=float)
    r = np.asarray(var["r"].value, dtype=float)
    p, r = 0.5 * (p + p.T), 0.5 * (r + r.T)
    mu = max(float(np.asarray(var["mu"].value)), 0.0) if loop.sigma > 0 else 0.0
    mu2 = max(float(np.asarray(var["mu2"].value)), 0.0) if lag_q else 0.0
    g = max(float(np.asarray(var["g"].value)), 0.0) if gain else 0.0
    if gain:
        g *= 1.0 + 1e-9  # a hair above the optimum, so the re-check sees the strict inequality
    top, margin = -math.inf, 0.0
    for mat, scale in lag_lmi_matrices(loop, p, r, mu, g, tau, beta, gain, mu2):
        t, m = strict_nsd_gap(mat, scale)
        if t >= -m:
            return None
        top, margin = max(top, t), m if t >= top else margin
    if strict_nsd_gap(-p)[0] >= 0 or (tau > 0 and np.linalg.eigvalsh(r).min() < 0):
        return None
    return LagResult(
        p=p, r=r, multiplier=mu, gain=g, tau=tau, beta=beta, max_eig=top, margin=margin, lag_multiplier=mu2
    )


__all__ = ["MAX_VERTICES", "LagLoop", "LagResult", "lag_lmi_matrices", "lmi_lag"]
