"""Independent checks of the Theorem 1 and 2 designs.

Four independent routes to the same numbers:

1. **Riccati solvers** on the full ``2N x 2N`` eq. (37),
   ``A^T L + L A + c L^2 + I = 0`` with ``A = lam I`` and ``c = 1/gamma^2 - 2``, mapped to
   ``care``'s form ``A^T X + X A - X B R^-1 B^T X + Q = 0`` with ``B = Q = I`` and
   ``R = -(1/c) I``:

   * ``gamma > 1/sqrt2`` (``c < 0``): ``R`` is positive definite, the usual LQR-type ARE;
   * ``gamma < 1/sqrt2`` (``c > 0``): ``R`` is *negative* definite. Both ``control.care``
     and ``scipy.linalg.solve_continuous_are`` accept it (they work on the Hamiltonian
     pencil, whose eigenvalues ``+-s`` stay real and split) and return the stabilising
     root ``lam + c L = -s I``, not the paper's '+' root;
   * ``gamma = 1/sqrt2`` (``c = 0``): ``R`` would be infinite; (37) is the Lyapunov
     equation ``2 lam L + I = 0``, solved with ``control.lyap`` / scipy's Lyapunov solver.

2. **LMIs** in cvxpy solved by Clarabel:

   * the Riccati *inequality* whose extremal solution is the stabilising root
     (:func:`lmi_stabilizing_alpha`);
   * bounded-real-lemma analysis, the H-infinity norm of any ``StateSpace``
     (:func:`lmi_hinf_norm`);
   * BRL synthesis of the minimal alpha for a given gamma, by bisection on alpha over
     full-size BRL analyses (:func:`lmi_minimal_alpha`).

   Every solve must return status ``optimal``; the answer is re-verified with numpy
   eigenvalues of the LMI matrix, because cvxpy symmetrises PSD constraints silently.

3. **python-control** ``StateSpace`` models of the per-block closed loops and their
   H-infinity norms from ``control.norm``.

4. The exact values ``1/(alpha - lam)`` of :mod:`auv_hinf.design`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from typing import Any, Literal

import control as ct
import cvxpy as cp
import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from .design import (
    GAMMA_SINGULAR_TOL,
    alpha_minimal,
    alpha_paper,
    alpha_stabilizing,
    position_loop,
    theorem1_conditions,
)
from .vehicle import FloatArray
from .exceptions import DesignError, SolverError, require_finite


#: Riccati solvers agree with the closed form to round-off of a 2N-dimensional QZ/Schur.
ARE_RTOL = 1e-9
#: Interior-point LMI answers: Clarabel's default gap tolerance is 1e-8; the extremal
#: problems are flat near the optimum, so 1e-5 relative is the honest agreement.
LMI_RTOL = 1e-5
#: control.norm(sys, 'inf') without slycot bisects on Hamiltonian eigenvalues (~1e-6).
NORM_RTOL = 1e-5
#: Margin eps of strict LMIs (``P >> eps I``); far below every tolerance above.
LMI_MARGIN = 1e-9
#: Largest eigenvalue of an LMI matrix that must be negative semidefinite, after the
#: solve, still accepted as verified (absolute, relative to the matrix scale).
LMI_VERIFY_TOL = 1e-6
#: Relative width of the alpha bracket at which the BRL bisection stops.
BISECTION_RTOL = 1e-8

Solver = Literal["control", "scipy"]


def _rel(a: float, b: float, scale: float) -> float:
    """``|a - b| / max(|b|, scale)``; the floor avoids dividing by an exact zero."""
    return abs(a - b) / max(abs(b), scale)


def _solve(problem: cp.Problem, what: str) -> int:
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


def _verify_nsd(matrix: FloatArray, what: str) -> float:
    """Check that a numeric symmetric matrix is negative semidefinite; return its max eig."""
    sym = 0.5 * (matrix + matrix.T)
    top = float(np.linalg.eigvalsh(sym).max())
    scale = max(1.0, float(np.abs(sym).max()))
    if top > LMI_VERIFY_TOL * scale:
        raise SolverError(f"{what}: LMI not satisfied after solve (largest eigenvalue {top:.3g})")
    return top


# ---------------------------------------------------------------------------------------
# Riccati equation (37) on the full 2N problem
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RiccatiResult:
    """Solution of eq. (37) by one solver.

    Attributes
    ----------
    solver : str
        ``"control.care"``, ``"scipy.care"``, ``"control.lyap"`` or ``"scipy.lyap"``.
    regime : str
        ``"R>0"`` (gamma > 1/sqrt2), ``"R<0"`` (gamma < 1/sqrt2) or ``"lyapunov"``.
    alpha : float
        ``trace(L)/(2N)``, 1/s.
    structure_error : float
        ``max |L - alpha I|``: how far L is from a multiple of the identity.
    residual : float
        Max absolute entry of the left side of (37) at L.
    """

    solver: str
    regime: str
    alpha: float
    structure_error: float
    residual: float


def _require_real_solution(lam: float, gamma: float) -> None:
    cond = theorem1_conditions(lam, gamma)
    if not cond.gamma_ok:
        raise DesignError(f"gamma={gamma:.6g} below 1/sqrt(lambda^2+2)={cond.gamma_min:.6g}: (37) has no real solution")


def riccati_alpha(lam: float, gamma: float, n: int, *, solver: Solver = "control") -> RiccatiResult:
    """Solve eq. (37) for ``L`` (``2n x 2n``) with ``control`` or ``scipy``.

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        Bound with ``gamma >= 1/sqrt(lam^2+2)``.
    n : int
        Number of vehicles; the problem has size ``2n``.
    solver : {"control", "scipy"}
    """
    _require_real_solution(lam, gamma)
    size = 2 * _check_n(n)
    a = lam * np.eye(size)
    eye = np.eye(size)
    c = 1.0 / (gamma * gamma) - 2.0
    if abs(c) <= GAMMA_SINGULAR_TOL:
        regime = "lyapunov"
        if solver == "control":
            x = ct.lyap(a, eye)  # A X + X A^T + Q = 0
        else:
            x = sla.solve_continuous_lyapunov(a, -eye)  # A X + X A^H = Q
        name = f"{solver}.lyap"
    else:
        regime = "R>0" if c < 0 else "R<0"
        r = (-1.0 / c) * eye
        if solver == "control":
            x, _, _ = ct.care(a, eye, eye, r)
        else:
            x = sla.solve_continuous_are(a, eye, eye, r)
        name = f"{solver}.care"
    x = np.asarray(x, dtype=float)
    alpha = float(np.trace(x) / size)
    residual = a.T @ x + x @ a + c * x @ x + eye
    return RiccatiResult(
        solver=name,
        regime=regime,
        alpha=alpha,
        structure_error=float(np.abs(x - alpha * eye).max()),
        residual=float(np.abs(residual).max()),
    )


#: Cap on :func:`root_condition`, reached only within ~1e-8 of gamma_min.
ROOT_CONDITION_CAP = 1e4


def root_condition(lam: float, gamma: float) -> float:
    """Relative condition number ``1 + |lam|/s`` of the stabilising root, capped.

    At ``gamma = 1/sqrt(lam^2+2)`` the two roots of (37) merge (``s = 0``) and any
    solver's answer is only sqrt(eps)-accurate; the Riccati tolerance is scaled by this
    factor (and so is the Riccati-inequality LMI's, whose optimum has the same sensitivity)
    so that the check stays honest there instead of failing on round-off.
    """
    c = 1.0 / (gamma * gamma) - 2.0
    s = math.sqrt(max(lam * lam - c, 0.0))
    return min(ROOT_CONDITION_CAP, 1.0 + abs(lam) / s) if s > 0 else ROOT_CONDITION_CAP


def _check_n(n: int) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise DesignError(f"number of vehicles n must be an integer >= 2, got {n!r}")
    return int(n)


# ---------------------------------------------------------------------------------------
# LMIs (cvxpy + Clarabel)
# ---------------------------------------------------------------------------------------


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
    _require_real_solution(lam, gamma)
    size = 2 * _check_n(n)
    eye = np.eye(size)
    c = 1.0 / (gamma * gamma) - 2.0
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
    solves = _solve(problem, "Riccati-inequality LMI")
    lval = np.asarray(ell.value, dtype=float)
    max_eig = _verify_nsd(np.asarray(sym.value, dtype=float), "Riccati-inequality LMI")
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
    solves = _solve(problem, "bounded-real-lemma analysis LMI")
    max_eig = _verify_nsd(np.asarray(sym.value, dtype=float), "bounded-real-lemma analysis LMI")
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
    size = 2 * _check_n(n)
    problem, beta, t, sym = _brl_closed_loop_problem(size)
    solves = 0
    max_eig = -math.inf

    def norm(alpha: float) -> float:
        nonlocal solves, max_eig
        beta.value = alpha - lam_f
        solves += _solve(problem, "BRL synthesis LMI")
        max_eig = _verify_nsd(np.asarray(sym.value, dtype=float), "BRL synthesis LMI")
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


# ---------------------------------------------------------------------------------------
# python-control models of the per-block closed loops
# ---------------------------------------------------------------------------------------


def velocity_block(lam: float, alpha: float, dim: int = 2) -> ct.StateSpace:
    """Closed velocity loop ``Ze' = (lam - alpha) Ze + w``, output ``Ze`` (one block: dim 2)."""
    eye = np.eye(dim)
    return ct.ss((lam - alpha) * eye, eye, eye, np.zeros((dim, dim)), name="velocity_block")


def position_block(lam: float, alpha: float, k1: float, dim: int = 2) -> ct.StateSpace:
    """Theorem 2 loop ``[Xe; Ze]' = [[0, I], [-k1 I, (lam - alpha) I]] [Xe; Ze] + [0; I] w``.

    Output ``Ze``; one block has ``dim = 2``.
    """
    eye, zero = np.eye(dim), np.zeros((dim, dim))
    a = np.block([[zero, eye], [-k1 * eye, (lam - alpha) * eye]])
    b = np.vstack([zero, eye])
    c = np.hstack([zero, eye])
    return ct.ss(a, b, c, zero, name="position_block")


def hinf_norm(sys: ct.StateSpace) -> float:
    """H-infinity norm from ``control.norm(sys, 'inf')``; any warning it emits is an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return float(ct.norm(sys, "inf"))


# ---------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Check:
    """One comparison: ``value`` against ``reference`` with relative tolerance ``tol``."""

    name: str
    value: float
    reference: float
    rel_diff: float
    tol: float

    @property
    def ok(self) -> bool:
        """True when ``rel_diff <= tol``."""
        return self.rel_diff <= self.tol


@dataclass(frozen=True)
class CrosscheckReport:
    """Every alpha and norm for one ``(lam, gamma, n, k1)``, with the comparisons.

    ``alpha_*`` are in 1/s, norms in s. ``alpha_paper`` is ``None`` when gamma is below
    ``1/sqrt(lam^2+2)`` (then so are the stabilising and Riccati values).
    """

    lam: float
    gamma: float
    n: int
    k1: float
    conditions: dict[str, Any]
    alpha_paper: float | None
    alpha_stabilizing: float | None
    alpha_minimal: float
    alpha_care: float | None
    alpha_scipy_care: float | None
    alpha_lmi: float | None
    alpha_lmi_minimal: float
    paper_flags: tuple[str, ...]
    riccati_regime: str | None
    hinf_exact: float | None
    hinf_python_control: float | None
    hinf_lmi: float | None
    position_hinf_exact: float | None
    position_hinf_python_control: float | None
    checks: tuple[Check, ...] = field(default_factory=tuple)

    @property
    def max_rel_diff(self) -> float:
        """Largest relative disagreement over all checks."""
        return max((c.rel_diff for c in self.checks), default=0.0)

    @property
    def ok(self) -> bool:
        """True when every check is inside its tolerance."""
        return all(c.ok for c in self.checks)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary in the layout of ``auv-hinf design --json``."""
        return {
            "lambda": self.lam,
            "gamma": self.gamma,
            "n": self.n,
            "k1": self.k1,
            "conditions": self.conditions,
            "alpha": {
                "paper": self.alpha_paper,
                "stabilizing": self.alpha_stabilizing,
                "minimal": self.alpha_minimal,
                "care": self.alpha_care,
                "scipy_care": self.alpha_scipy_care,
                "lmi": self.alpha_lmi,
                "lmi_minimal": self.alpha_lmi_minimal,
            },
            "riccati_regime": self.riccati_regime,
            "paper_flags": list(self.paper_flags),
            "closed_loop_hinf": {
                "exact": self.hinf_exact,
                "python_control": self.hinf_python_control,
                "lmi": self.hinf_lmi,
            },
            "position_loop_hinf": self.position_hinf_exact,
            "position_loop_hinf_python_control": self.position_hinf_python_control,
            "checks": [dict(asdict(c), ok=c.ok) for c in self.checks],
            "max_rel_diff": self.max_rel_diff,
            "crosscheck_ok": self.ok,
        }


def crosscheck(lam: float, gamma: float, n: int = 3, k1: float = 0.2) -> CrosscheckReport:
    """Compute every alpha and closed-loop norm four ways and compare them.

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        Requested bound (> 0).
    n : int
        Number of vehicles; Riccati and LMI problems are solved at full size ``2n``.
    k1 : float
        Theorem 2 position gain (> 0, 1/s^2).

    Returns
    -------
    CrosscheckReport
        With per-check tolerances :data:`ARE_RTOL`, :data:`LMI_RTOL`, :data:`NORM_RTOL`.
    """
    cond = theorem1_conditions(lam, gamma)
    if not cond.lam_negative:
        raise DesignError(f"lambda must be < 0, got {lam!r}")
    n = _check_n(n)
    if require_finite("k1", k1) <= 0:
        raise DesignError(f"k1 must be > 0, got {k1!r}")
    scale = abs(lam) + 1.0 / gamma  # natural size of alpha - lam
    floor = 1e-3 * scale
    checks: list[Check] = []

    def add(name: str, value: float, reference: float, tol: float) -> None:
        checks.append(Check(name, value, reference, _rel(value, reference, floor), tol))

    minimal = alpha_minimal(lam, gamma)
    lmi_min = lmi_minimal_alpha(lam, gamma, n)
    # The BRL bisection pins down beta = alpha - lam (the loop's pole), so compare on it.
    add("BRL-synthesis alpha - lam vs closed form", lmi_min.value - lam, minimal.alpha - lam, LMI_RTOL)

    paper = stab = None
    care_r = scipy_r = None
    lmi_stab = None
    hinf_pc = hinf_lmi = pos_exact = pos_pc = None
    if cond.gamma_ok:
        paper = alpha_paper(lam, gamma)
        stab = alpha_stabilizing(lam, gamma)
        care_r = riccati_alpha(lam, gamma, n, solver="control")
        scipy_r = riccati_alpha(lam, gamma, n, solver="scipy")
        lmi_stab = lmi_stabilizing_alpha(lam, gamma, n)
        are_tol = ARE_RTOL * root_condition(lam, gamma)
        add("control.care alpha vs stabilizing", care_r.alpha, stab.alpha, are_tol)
        add("scipy care alpha vs stabilizing", scipy_r.alpha, stab.alpha, are_tol)
        add("control.care max |L - alpha I|", care_r.structure_error, 0.0, ARE_RTOL)
        add("Riccati-inequality LMI alpha vs stabilizing", lmi_stab.value, stab.alpha, LMI_RTOL * root_condition(lam, gamma))
        vel = velocity_block(lam, stab.alpha)
        hinf_pc = hinf_norm(vel)
        hinf_lmi = lmi_hinf_norm(vel).value
        add("python-control ||T|| vs 1/(alpha - lam)", hinf_pc, stab.closed_loop_hinf, NORM_RTOL)
        add("BRL LMI ||T|| vs 1/(alpha - lam)", hinf_lmi, stab.closed_loop_hinf, LMI_RTOL)
        pos = position_loop(lam, stab.alpha, k1)
        pos_exact = pos.hinf
        pos_pc = hinf_norm(position_block(lam, stab.alpha, k1))
        add("python-control position loop vs 1/(alpha - lam)", pos_pc, pos.hinf, NORM_RTOL)

    return CrosscheckReport(
        lam=float(lam),
        gamma=float(gamma),
        n=n,
        k1=float(k1),
        conditions=cond.to_dict(),
        alpha_paper=None if paper is None else paper.alpha,
        alpha_stabilizing=None if stab is None else stab.alpha,
        alpha_minimal=minimal.alpha,
        alpha_care=None if care_r is None else care_r.alpha,
        alpha_scipy_care=None if scipy_r is None else scipy_r.alpha,
        alpha_lmi=None if lmi_stab is None else lmi_stab.value,
        alpha_lmi_minimal=lmi_min.value,
        paper_flags=(
            ("infeasible: gamma below 1/sqrt(lambda^2+2); eq. (32) and the stabilising root do not exist, only the minimal gain",)
            if paper is None else paper.flags
        ),
        riccati_regime=None if care_r is None else care_r.regime,
        hinf_exact=None if stab is None else stab.closed_loop_hinf,
        hinf_python_control=hinf_pc,
        hinf_lmi=hinf_lmi,
        position_hinf_exact=pos_exact,
        position_hinf_python_control=pos_pc,
        checks=tuple(checks),
    )
