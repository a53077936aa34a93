"""Linear matrix inequalities in cvxpy, solved by Clarabel: the only module that imports cvxpy.

* the Riccati *inequality* whose extremal solution is the stabilising root of eq. (37)
  (:func:`lmi_stabilizing_alpha`);
* bounded-real-lemma analysis, the H-infinity norm of any ``StateSpace``
  (:func:`lmi_hinf_norm`);
* BRL synthesis of the minimal alpha for a given gamma, by bisection on alpha over full-size
  BRL analyses (:func:`lmi_minimal_alpha`);
* closed-loop Lyapunov LMIs of the position and heading error loops, for decay rates
  (:func:`lmi_position_lyapunov`, :func:`lmi_heading_lyapunov`) and for invariant
  regions (:func:`lmi_position_region`, :func:`lmi_heading_region`).

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
import scipy.linalg as sla

from ._typing import FloatArray
from .design import discriminant, riccati_c, riccati_regime
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
    closed loops), or fails with a numerical error (cvxpy's own ``SolverError``). Such a
    solve is retried with the settings in :data:`_RETRY_SETTINGS`; any status other than
    ``optimal`` after that raises :class:`auv_hinf.exceptions.SolverError` (never cvxpy's).
    Warnings cvxpy emits for an attempt are silenced because the retry decides.
    """
    solves = 0
    status: str | None = None
    failure: Exception | None = None
    for settings in ({}, *_RETRY_SETTINGS):
        solves += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                problem.solve(solver=cp.CLARABEL, **settings)
        except BaseException as exc:
            # cvxpy raises its own SolverError when Clarabel stops on a numerical error, and
            # Clarabel's Rust core can panic (pyo3's PanicException, a BaseException) on a
            # degenerate cone; problem.status may then be stale (a cached problem's previous
            # solve), so the attempt's status is recorded as None and the next settings are
            # tried. Interrupts and anything else propagate unchanged.
            failed = isinstance(exc, (cp.error.SolverError, ArithmeticError, ValueError)) or (
                type(exc).__name__ == "PanicException"
            )
            if not failed or isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            status, failure = None, exc if isinstance(exc, Exception) else RuntimeError(str(exc))
            continue
        status, failure = problem.status, None
        if status != cp.OPTIMAL_INACCURATE:
            break
    if status != cp.OPTIMAL:
        detail = f"solver error {failure}" if status is None else f"status {status!r}"
        raise SolverError(
            f"{what}: Clarabel returned {detail} after {solves} attempt(s), expected 'optimal'"
        ) from failure
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
    formulation : str
        Which equivalent formulation was solved (e.g. ``"normalised Schur, c<0"``,
        ``"balanced"``, ``"modal+balanced"``), for the cross-check report.
    """

    value: float
    status: str
    solves: int
    max_eig: float
    structure_error: float = 0.0
    formulation: str = ""


def lmi_stabilizing_alpha(lam: float, gamma: float, n: int) -> LmiResult:
    """Stabilising solution of (37) as the extremal solution of a Riccati inequality.

    The problem is first normalised by ``sigma = sqrt(lam^2 + |c|)`` (1/s): with
    ``l = lam/sigma``, ``k = c/sigma^2`` and ``M = sigma L``, (37) reads
    ``k M^2 + 2 l M + I = 0`` with ``l^2 + |k| = 1``, and its stabilising root lies in
    ``[1/2, sqrt 2]`` whatever the scale of lambda and gamma. The quadratic term is put in
    Schur form with a ``sqrt|k|`` congruence, so no entry grows like ``1/|c|`` near
    ``gamma = 1/sqrt2``. By :func:`auv_hinf.design.riccati_regime`:

    * ``"R>0"`` (``k < 0``): maximise ``trace(M)`` s.t.
      ``[[2 l M + I, sqrt|k| M], [sqrt|k| M, I]] >= 0``;
    * ``"R<0"`` and ``"double-root"`` (``k > 0``): minimise ``trace(M)`` s.t.
      ``[[2 l M + I, sqrt(k) M], [sqrt(k) M, -I]] <= 0``;
    * ``"lyapunov"``: minimise ``trace(M)`` s.t. ``2 l M + I <= 0``.

    In each case the optimum is the root with ``lam + c alpha = -s``, the stabilising one;
    ``alpha = trace(M) / (2 n sigma)``. At a double root (``"double-root"``, ``k > 0``) the
    feasible set of the ``k > 0`` LMI shrinks to a point or is empty by round-off (Clarabel
    can panic on it), so the inequality ``k M^2 + 2 l M + I <= 0``, i.e.
    ``(k M + l I)^2 <= disc' I`` with ``disc' = l^2 - k``, is solved in its equivalent linear
    form ``-h I <= k M + l I <= h I``, ``h = sqrt(max(disc', 0))``; its minimal trace is the
    same root. Recorded as formulation
    ``"double-root linear"``.

    Raises
    ------
    DesignError
        If gamma is below ``1/sqrt(lam^2 + 2)``.
    SolverError
        If Clarabel does not return ``optimal`` or the LMI fails verification.
    """
    require_real_solution(lam, gamma)
    size = 2 * require_fleet_size(n)
    eye = np.eye(size)
    c = riccati_c(gamma)
    sigma = math.sqrt(lam * lam + abs(c))
    l_n, k_n = lam / sigma, c / (sigma * sigma)
    regime = riccati_regime(lam, gamma)
    m_var = cp.Variable((size, size), symmetric=True)
    top = 2.0 * l_n * m_var + eye
    sign: float
    objective: cp.Minimize | cp.Maximize
    if regime == "lyapunov":
        mat, sign, formulation = top, 1.0, "normalised Lyapunov"
        objective = cp.Minimize(cp.trace(m_var))
    elif k_n < 0:
        root = math.sqrt(-k_n)
        mat = cp.bmat([[top, root * m_var], [root * m_var, eye]])
        sign, formulation = -1.0, "normalised Schur, c<0"  # mat >= 0  <=>  -mat <= 0
        objective = cp.Maximize(cp.trace(m_var))
    else:
        root = math.sqrt(k_n)
        mat = cp.bmat([[top, root * m_var], [root * m_var, -eye]])
        sign, formulation = 1.0, "normalised Schur, c>0"
        objective = cp.Minimize(cp.trace(m_var))
    sym = sign * 0.5 * (mat + mat.T)
    if regime != "double-root" or k_n <= 0:
        problem = cp.Problem(objective, [sym << 0, m_var >> LMI_MARGIN * eye])
        solves = solve(problem, "Riccati-inequality LMI")
        max_eig = verify_nsd(np.asarray(sym.value, dtype=float), "Riccati-inequality LMI")
    else:
        # Normalised discriminant l^2 - k (>= -1e-12 * scale by the input check); k M + l I
        # is bounded on both sides by h = sqrt(max(disc', 0)).
        half = math.sqrt(max(discriminant(lam, gamma) / (sigma * sigma), 0.0))
        lin = k_n * m_var + l_n * eye
        problem = cp.Problem(cp.Minimize(cp.trace(m_var)), [lin << half * eye, -lin << half * eye])
        solves = solve(problem, "Riccati-inequality LMI (double root)")
        lin_val = np.asarray(lin.value, dtype=float)
        max_eig = verify_nsd(lin_val - half * eye, "Riccati-inequality LMI (double root)")
        verify_nsd(-lin_val - half * eye, "Riccati-inequality LMI (double root)")
        formulation = "double-root linear"
    mval = np.asarray(m_var.value, dtype=float) / sigma
    alpha = float(np.trace(mval) / size)
    return LmiResult(
        value=alpha,
        status=problem.status,
        solves=solves,
        max_eig=max_eig,
        structure_error=float(np.abs(mval - alpha * eye).max()),
        formulation=formulation,
    )


def lmi_hinf_norm(sys: ct.StateSpace) -> LmiResult:
    """H-infinity norm of a stable ``StateSpace`` by the bounded-real lemma.

    Minimise ``g`` over ``P >> 0`` subject to
    ``[[A^T P + P A, P B, C^T], [B^T P, -g I, D^T], [C, D, -g I]] <= 0``.

    The norm is invariant under a state similarity, under the frequency scaling
    ``G(s) -> G(w0 s)`` and scales with a common factor on ``C, D``; the LMI is solved on an
    equivalent, well-scaled realisation:

    1. ``"balanced"``: time scaled by ``w0`` = geometric mean of the smallest and largest
       pole magnitude, states balanced by a diagonal similarity
       (``scipy.linalg.matrix_balance`` of ``[[A, B], [C, 0]]``, state part only), and
       ``C, D`` divided by a lower bound ``k`` of the norm (the largest singular value of
       ``G`` at 0 and at the pole magnitudes), so that the optimal ``g`` is near 1;
    2. ``"modal+balanced"``, if Clarabel fails on 1 (very stiff systems, e.g. poles from
       -1e8 to -1e-3): the same on python-control's modal (block-diagonal) realisation,
       provided its eigenvector basis has condition number below :data:`MODAL_COND_MAX`.

    Raises
    ------
    DesignError
        If the system is not asymptotically stable (the LMI would be infeasible).
    SolverError
        If every formulation fails.
    """
    a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    nx, nu, ny = a.shape[0], b.shape[1], c.shape[0]
    poles = np.linalg.eigvals(a) if nx else np.zeros(0)
    if np.any(poles.real >= 0):
        raise DesignError(f"lmi_hinf_norm needs an asymptotically stable system; poles {poles}")
    freqs = np.concatenate([[0.0], np.abs(poles)])
    gains = [float(np.linalg.norm(d, 2))] + [
        float(np.linalg.norm(c @ np.linalg.solve(1j * w * np.eye(nx) - a, b) + d, 2)) for w in freqs
    ] if nx else [float(np.linalg.norm(d, 2))]
    k = max(gains)
    if not k > 0.0 or not math.isfinite(k):
        k = 1.0

    def scaled(a0: FloatArray, b0: FloatArray, c0: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        mags = np.abs(poles)
        w0 = math.sqrt(float(mags.min() * mags.max()))
        a1, b1, c1 = a0 / w0, b0 / math.sqrt(w0), c0 / (math.sqrt(w0) * k)
        side = nx + max(nu, ny)
        big = np.zeros((side, side))
        big[:nx, :nx], big[:nx, nx:nx + nu], big[nx:nx + ny, :nx] = a1, b1, c1
        _, (scale, _) = sla.matrix_balance(big, permute=False, separate=True)
        t = np.asarray(scale[:nx], dtype=float)
        return a1 * t[None, :] / t[:, None], b1 / t[:, None], c1 * t[None, :]

    def brl(a0: FloatArray, b0: FloatArray, c0: FloatArray, d0: FloatArray, what: str) -> tuple[float, int, float]:
        p = cp.Variable((nx, nx), symmetric=True)
        g = cp.Variable()
        mat = cp.bmat(
            [
                [a0.T @ p + p @ a0, p @ b0, c0.T],
                [b0.T @ p, -g * np.eye(nu), d0.T],
                [c0, d0, -g * np.eye(ny)],
            ]
        )
        sym = 0.5 * (mat + mat.T)
        problem = cp.Problem(cp.Minimize(g), [sym << 0, p >> LMI_MARGIN * np.eye(nx)])
        solves = solve(problem, what)
        max_eig = verify_nsd(np.asarray(sym.value, dtype=float), what)
        return float(np.asarray(g.value)), solves, max_eig

    if nx == 0:
        return LmiResult(
            value=float(np.linalg.norm(d, 2)), status=cp.OPTIMAL, solves=0, max_eig=0.0, formulation="static"
        )
    what = "bounded-real-lemma analysis LMI"
    total = 0
    try:
        g_val, total, max_eig = brl(*scaled(a, b, c), d / k, what)
        return LmiResult(value=k * g_val, status=cp.OPTIMAL, solves=total, max_eig=max_eig, formulation="balanced")
    except SolverError as exc:
        first = exc
        total += len(_RETRY_SETTINGS) + 1
    try:
        modal, transform = ct.canonical_form(sys, "modal")
    except (ValueError, np.linalg.LinAlgError, ct.ControlArgument) as exc:
        raise SolverError(f"{what}: balanced form failed ({first}); no modal form ({exc})") from first
    if np.linalg.cond(np.asarray(transform, dtype=float)) > MODAL_COND_MAX:
        raise SolverError(f"{what}: balanced form failed ({first}); modal basis too ill-conditioned") from first
    am, bm, cm = (np.asarray(m, dtype=float) for m in (modal.A, modal.B, modal.C))
    g_val, solves, max_eig = brl(*scaled(am, bm, cm), d / k, what + " (modal)")
    return LmiResult(value=k * g_val, status=cp.OPTIMAL, solves=total + solves, max_eig=max_eig,
                     formulation="modal+balanced")


#: Largest condition number of the modal basis accepted by :func:`lmi_hinf_norm`: the
#: similarity then changes the norm by at most ~1e8 * eps ~ 1e-8 relative, below LMI_RTOL.
MODAL_COND_MAX = 1e8


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
    ``(lam - alpha) I`` and compares the certified ``||T||`` with ``gamma``; the norm
    is decreasing in alpha, so bisection finds the boundary. Returns 0 when ``alpha = 0``
    already meets the bound.

    The problem is normalised by ``S = |lam| + 1/gamma`` (1/s): frequencies and gains are
    divided by ``S``, the bound becomes ``gamma S >= 1``, and the boundary pole
    ``beta = alpha - lam`` lies in ``(1/2, 1]`` in these units whatever the scale of lambda
    and gamma. The only LMI that could see a tiny pole is the one at ``alpha = 0``; it is
    skipped when the DC gain ``1/|lam|`` of that loop (a lower bound of its norm, evaluated
    with numpy) already exceeds gamma.
    """
    lam_f = require_finite("lambda", lam)
    g = require_finite("gamma", gamma)
    if g <= 0:
        raise DesignError(f"gamma must be > 0, got {g!r}")
    size = 2 * require_fleet_size(n)
    problem, beta, t, sym = _brl_closed_loop_problem(size)
    scale = abs(lam_f) + 1.0 / g
    lam_n, g_n = lam_f / scale, g * scale
    solves = 0
    max_eig = -math.inf

    def norm(alpha_n: float) -> float:
        nonlocal solves, max_eig
        beta.value = alpha_n - lam_n
        solves += solve(problem, "BRL synthesis LMI")
        max_eig = verify_nsd(np.asarray(sym.value, dtype=float), "BRL synthesis LMI")
        return float(np.asarray(t.value))

    formulation = f"normalised by |lambda| + 1/gamma = {scale:.6g} 1/s"
    if lam_f < 0:
        a0 = lam_n * np.eye(size)
        dc_gain = float(np.linalg.norm(np.linalg.solve(-a0, np.eye(size)), 2))
        if dc_gain <= g_n and norm(0.0) <= g_n:
            return LmiResult(value=0.0, status=cp.OPTIMAL, solves=solves, max_eig=max_eig, formulation=formulation)
    lo = max(0.0, lam_n) + 1e-12
    hi = max(1.0, 2.0 * (1.0 / g_n + abs(lam_n)))
    while norm(hi) > g_n:
        hi *= 2.0
    while hi - lo > BISECTION_RTOL * max(1.0, hi):
        mid = 0.5 * (lo + hi)
        if norm(mid) <= g_n:
            hi = mid
        else:
            lo = mid
    return LmiResult(value=hi * scale, status=cp.OPTIMAL, solves=solves, max_eig=max_eig, formulation=formulation)


# --------------------------------------------------------------------------------------
# Closed-loop Lyapunov LMIs (position and heading error loops), used by ``closed_loop`` and
# ``region``. Every returned matrix is re-verified with ``numpy.linalg.eigvalsh`` against a
# strict round-off margin (:func:`strict_nsd_gap`).
# --------------------------------------------------------------------------------------

#: Strictness imposed inside the SDPs: ``LMI <= -LYAP_STRICT_RTOL * trace(P) I``. Clarabel
#: meets its constraints to about 1e-8 relative, so a margin ten times larger survives the
#: solver's round-off and the eigenvalue re-check below sees a strictly negative matrix.
LYAP_STRICT_RTOL = 1e-7
#: Multiple of ``n * eps * scale`` a verified eigenvalue must clear. ``eigvalsh`` is
#: backward stable (error <= a small multiple of ``n eps ||M||``) and assembling ``M`` from
#: its terms adds a few ulps of the largest term, both covered by this factor.
EIG_ROUNDOFF_FACTOR = 64.0

#: cvxpy's top-level names (bmat, trace, reshape) are implicit re-exports, which strict mypy
#: does not see; they are reached through this ``Any`` alias.
_CP: Any = cp

_E1 = np.array([[1.0, 0.0]])
_E2 = np.array([[0.0, 1.0]])


def roundoff_margin(size: int, scale: float) -> float:
    """Eigenvalue round-off allowance ``EIG_ROUNDOFF_FACTOR * n * eps * scale``."""
    return EIG_ROUNDOFF_FACTOR * size * float(np.finfo(float).eps) * max(scale, 1e-300)


def strict_nsd_gap(matrix: FloatArray, scale: float = 0.0) -> tuple[float, float]:
    """Largest eigenvalue of the symmetric part of ``matrix`` and the round-off margin.

    The matrix is *strictly* negative definite, provably and despite round-off, when the
    first value is below minus the second. ``scale`` is the size of the terms ``matrix`` was
    assembled from (defaults to its own norm).
    """
    sym = 0.5 * (matrix + matrix.T)
    eigs = np.linalg.eigvalsh(sym)
    norm = float(np.abs(eigs).max())
    return float(eigs.max()), roundoff_margin(sym.shape[0], max(norm, scale))


def position_lmi_matrix(
    p2: FloatArray, tau: float, lam: float, alpha: float, k1: float, sigma: float, beta: float
) -> tuple[FloatArray, float]:
    """Numeric position-loop LMI matrix and the scale of its terms.

    ``[[a^T P2 + P2 a + 2 beta P2 + tau sigma^2 c^T c, P2 b], [b^T P2, -tau]]`` with
    ``a = [[0, 1], [-k1, lam - alpha]]``, ``b = [0, 1]^T``, ``c = [0, 1]`` (units: P2 is
    dimensionless up to a common scale, the entries are 1/s times that scale).
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
    """Numeric ``A(c)^T Q + Q A(c) + 2 beta Q`` at ``c = c_lo, c_hi`` with term scales."""
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
    what: str, matrix: FloatArray, mats: list[tuple[FloatArray, float]], tau: float, beta: float, objective: float,
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
    """
    problem, par, q = _heading_gevp()
    par["a_lo"].value = _heading_a(k1psi, c_range[0])
    par["a_hi"].value = _heading_a(k1psi, c_range[1])
    par["beta"].value = beta
    solve(problem, "heading-loop Lyapunov LMI")
    qv = np.asarray(q.value, dtype=float)
    qv = 0.5 * (qv + qv.T)
    return _verify_lyapunov("heading LMI", qv, heading_lmi_matrices(qv, k1psi, c_range, beta), 0.0, beta,
                            _value(problem))


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
    """``P2`` whose invariant ellipsoid through the start box ``||e|| <= rp, ||e'|| <= rv``
    has the smallest velocity extent ``sqrt((P2^-1)_22)`` (rp, rv > 0 not both zero).

    Homogeneous LMI (``beta = 0``, tau free, strict by :data:`LYAP_STRICT_RTOL`).

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
    res = _verify_lyapunov("position region", p2, [position_lmi_matrix(p2, t, lam, alpha, k1, sigma, 0.0)], t, 0.0,
                           _value(problem))
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
    """``Q`` whose invariant ellipsoid through ``|e_psi| <= rh, |e_psi'| <= rr`` best fits
    the budgets ``(B_psi^2, B_r^2)``: minimise s with ``(Q^-1)_11 <= s B_psi^2`` and
    ``(Q^-1)_22 <= s B_r^2`` (s <= 1 means both budgets are met). Homogeneous LMIs at the
    two vertices of ``c_range``, strict by :data:`LYAP_STRICT_RTOL`.

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
    res = _verify_lyapunov("heading region", qv, heading_lmi_matrices(qv, k1psi, c_range, 0.0), 0.0, 0.0,
                           _value(problem))
    if res is None:
        raise SolverError("heading-region SDP: the returned Q fails the strict eigvalsh re-check")
    return res
