"""Linear matrix inequalities in cvxpy, solved by Clarabel: the only module that imports cvxpy.

* the Riccati *inequality* whose extremal solution is the stabilising root of eq. (37)
  (:func:`lmi_stabilizing_alpha`);
* bounded-real-lemma analysis, the H-infinity norm of any ``StateSpace``
  (:func:`lmi_hinf_norm`);
* BRL synthesis of the minimal alpha for a given gamma, by bisection on alpha over full-size
  BRL analyses (:func:`lmi_minimal_alpha`).

Every solve must return status ``optimal``; the answer is re-verified with numpy eigenvalues of
the LMI matrix, because cvxpy symmetrises PSD constraints silently.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import control as ct
import cvxpy as cp
import numpy as np

from ._typing import FloatArray
from .design import GAMMA_SINGULAR_TOL, riccati_c
from .exceptions import DesignError, SolverError, require_finite, require_fleet_size
from .riccati import require_real_solution

#: Interior-point LMI answers: Clarabel's default gap tolerance is 1e-8; the extremal
#: problems are flat near the optimum, so 1e-5 relative is the honest agreement.
LMI_RTOL = 1e-5
#: Margin eps of strict LMIs (``P >> eps I``); far below every tolerance above.
LMI_MARGIN = 1e-9
#: Largest eigenvalue of an LMI matrix that must be negative semidefinite, after the
#: solve, still accepted as verified (absolute, relative to the matrix scale).
LMI_VERIFY_TOL = 1e-6
#: Relative width of the alpha bracket at which the BRL bisection stops.
BISECTION_RTOL = 1e-8


def solve(problem: cp.Problem, what: str) -> int:
    """Solve with Clarabel and insist on status ``optimal``; return the number of solves.

    The BRL problems here have a large face of optimal P (all channels are identical), and
    Clarabel occasionally stops at ``optimal_inaccurate`` on them (seen on 1 of 107 random
    closed loops). Such a solve is retried with the settings in :data:`_RETRY_SETTINGS`;
    any status other than ``optimal`` after that raises :class:`SolverError`. Warnings
    cvxpy emits for an attempt are silenced because the retry decides.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        problem.solve(solver=cp.CLARABEL)
    solves = 1
    for retry in _RETRY_SETTINGS:
        if problem.status != cp.OPTIMAL_INACCURATE:
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.CLARABEL, **retry)
        solves += 1
    if problem.status != cp.OPTIMAL:
        raise SolverError(
            f"{what}: Clarabel returned status {problem.status!r} after {solves} attempt(s), expected 'optimal'"
        )
    return solves


#: Settings tried, in order, after an ``optimal_inaccurate`` answer.
_RETRY_SETTINGS: tuple[dict[str, Any], ...] = (
    {"equilibrate_enable": False},
    {"direct_solve_method": "qdldl", "static_regularization_constant": 1e-9},
)


def verify_nsd(matrix: FloatArray, what: str) -> float:
    """Check that a numeric symmetric matrix is negative semidefinite; return its max eig."""
    sym = 0.5 * (matrix + matrix.T)
    top = float(np.linalg.eigvalsh(sym).max())
    scale = max(1.0, float(np.abs(sym).max()))
    if top > LMI_VERIFY_TOL * scale:
        raise SolverError(f"{what}: LMI not satisfied after solve (largest eigenvalue {top:.3g})")
    return top


@dataclass(frozen=True)
class LmiResult:
    """Answer of one LMI computation, verified after the solve.

    Attributes
    ----------
    value : float
        The alpha (1/s) or the norm (s) found.
    status : str
        cvxpy status of the last solve (always ``"optimal"`` when returned).
    solves : int
        Number of SDPs solved (more than one for bisection).
    max_eig : float
        Largest eigenvalue of the verified negative-semidefinite LMI matrix.
    structure_error : float
        For matrix answers, distance from a multiple of the identity (0 otherwise).
    """

    value: float
    status: str
    solves: int
    max_eig: float
    structure_error: float = 0.0


def lmi_stabilizing_alpha(lam: float, gamma: float, n: int) -> LmiResult:
    """Stabilising solution of (37) as the extremal solution of a Riccati inequality.

    * ``c < 0``: the maximal ``L`` with ``2 lam L + I - |c| L^2 >= 0``, i.e. maximise
      ``trace(L)`` s.t. ``[[2 lam L + I, L], [L, I/|c|]] >= 0``;
    * ``c > 0``: the minimal ``L`` with ``2 lam L + I + c L^2 <= 0``, i.e. minimise
      ``trace(L)`` s.t. ``[[2 lam L + I, L], [L, -I/c]] <= 0``;
    * ``c = 0``: minimise ``trace(L)`` s.t. ``2 lam L + I <= 0``.

    In each case the optimum is the root with ``lam + c alpha = -s``, the stabilising one.
    """
    require_real_solution(lam, gamma)
    size = 2 * require_fleet_size(n)
    eye = np.eye(size)
    c = riccati_c(gamma)
    ell = cp.Variable((size, size), symmetric=True)
    top = 2.0 * lam * ell + eye
    sign: float
    objective: cp.Minimize | cp.Maximize
    if abs(c) <= GAMMA_SINGULAR_TOL:
        mat = top
        sign = 1.0  # mat <= 0
        objective = cp.Minimize(cp.trace(ell))
    elif c < 0:
        mat = cp.bmat([[top, ell], [ell, eye / abs(c)]])
        sign = -1.0  # mat >= 0  <=>  -mat <= 0
        objective = cp.Maximize(cp.trace(ell))
    else:
        mat = cp.bmat([[top, ell], [ell, -eye / c]])
        sign = 1.0
        objective = cp.Minimize(cp.trace(ell))
    sym = sign * 0.5 * (mat + mat.T)
    problem = cp.Problem(objective, [sym << 0, ell >> LMI_MARGIN * eye])
    solves = solve(problem, "Riccati-inequality LMI")
    lval = np.asarray(ell.value, dtype=float)
    max_eig = verify_nsd(np.asarray(sym.value, dtype=float), "Riccati-inequality LMI")
    alpha = float(np.trace(lval) / size)
    return LmiResult(
        value=alpha,
        status=problem.status,
        solves=solves,
        max_eig=max_eig,
        structure_error=float(np.abs(lval - alpha * eye).max()),
    )


def lmi_hinf_norm(sys: ct.StateSpace) -> LmiResult:
    """H-infinity norm of a stable ``StateSpace`` by the bounded-real lemma.

    Minimise ``g`` over ``P >> 0`` subject to
    ``[[A^T P + P A, P B, C^T], [B^T P, -g I, D^T], [C, D, -g I]] <= 0``.
    """
    a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    nx, nu, ny = a.shape[0], b.shape[1], c.shape[0]
    p = cp.Variable((nx, nx), symmetric=True)
    g = cp.Variable()
    mat = cp.bmat(
        [
            [a.T @ p + p @ a, p @ b, c.T],
            [b.T @ p, -g * np.eye(nu), d.T],
            [c, d, -g * np.eye(ny)],
        ]
    )
    sym = 0.5 * (mat + mat.T)
    problem = cp.Problem(cp.Minimize(g), [sym << 0, p >> LMI_MARGIN * np.eye(nx)])
    solves = solve(problem, "bounded-real-lemma analysis LMI")
    max_eig = verify_nsd(np.asarray(sym.value, dtype=float), "bounded-real-lemma analysis LMI")
    return LmiResult(value=float(np.asarray(g.value)), status=problem.status, solves=solves, max_eig=max_eig)


@lru_cache(maxsize=32)
def _brl_closed_loop_problem(size: int) -> tuple[cp.Problem, cp.Parameter, cp.Variable, cp.Expression]:
    """Parametrised BRL analysis of ``x' = -beta x + w, z = x``: minimise the bound t.

    ``beta = alpha - lam``; the LMI is the three-block bounded-real form
    ``[[-2 beta P, P, I], [P, -t I, 0], [I, 0, -t I]] <= 0`` (``||T||_inf <= t``), which
    Clarabel solves more reliably than the two-block Schur form.
    """
    eye, zero = np.eye(size), np.zeros((size, size))
    beta = cp.Parameter(nonneg=True)
    p = cp.Variable((size, size), symmetric=True)
    t = cp.Variable()
    mat = cp.bmat([[-2.0 * beta * p, p, eye], [p, -t * eye, zero], [eye, zero, -t * eye]])
    sym = 0.5 * (mat + mat.T)
    problem = cp.Problem(cp.Minimize(t), [sym << 0, p >> LMI_MARGIN * eye])
    return problem, beta, t, sym


def lmi_minimal_alpha(lam: float, gamma: float, n: int) -> LmiResult:
    """Smallest alpha with ``||T||_inf <= gamma`` by bisection on full-size BRL LMIs.

    Each step solves the BRL analysis LMI of the ``2n``-state closed loop
    ``(lam - alpha) I`` and compares the certified ``||T||^2`` with ``gamma^2``; the norm
    is decreasing in alpha, so bisection finds the boundary. Returns 0 when ``alpha = 0``
    already meets the bound.
    """
    lam_f = require_finite("lambda", lam)
    g = require_finite("gamma", gamma)
    if g <= 0:
        raise DesignError(f"gamma must be > 0, got {g!r}")
    size = 2 * require_fleet_size(n)
    problem, beta, t, sym = _brl_closed_loop_problem(size)
    solves = 0
    max_eig = -math.inf

    def norm(alpha: float) -> float:
        nonlocal solves, max_eig
        beta.value = alpha - lam_f
        solves += solve(problem, "BRL synthesis LMI")
        max_eig = verify_nsd(np.asarray(sym.value, dtype=float), "BRL synthesis LMI")
        return float(np.asarray(t.value))

    lo = max(0.0, lam_f) + 1e-12
    if lam_f < 0 and norm(0.0) <= g:
        return LmiResult(value=0.0, status=problem.status, solves=solves, max_eig=max_eig)
    hi = max(1.0, 2.0 * (1.0 / g + abs(lam_f)))
    while norm(hi) > g:
        hi *= 2.0
    while hi - lo > BISECTION_RTOL * max(1.0, hi):
        mid = 0.5 * (lo + hi)
        if norm(mid) <= g:
            hi = mid
        else:
            lo = mid
    return LmiResult(value=hi, status=problem.status, solves=solves, max_eig=max_eig)
