"""LMIs of the Theorem 1 design: Riccati inequality, bounded-real-lemma norm, BRL synthesis."""

from __future__ import annotations

import math
from functools import lru_cache

import control as ct
import cvxpy as cp
import numpy as np
import scipy.linalg as sla

from auv_hinf._typing import FloatArray
from auv_hinf.design.riccati import require_real_solution
from auv_hinf.design.theorem1 import discriminant, riccati_c, riccati_regime
from auv_hinf.exceptions import DesignError, SolverError, require_finite, require_fleet_size
from auv_hinf.numerics.bisection import bisect
from auv_hinf.numerics.lmi import _RETRY_SETTINGS, BISECTION_RTOL, LMI_MARGIN, LmiResult, solve, verify_nsd

#: States of one vehicle's block of the linearised fleet (its two horizontal axes).
BLOCK_STATES = 2


def vehicle_block(n: int) -> int:
    """The size the Theorem 1 LMIs are solved at for a fleet of ``n`` vehicles: one vehicle's block.

    Every matrix of those LMIs is a scalar multiple of the ``2n x 2n`` identity, so the fleet's
    LMI is the direct sum of ``2n`` copies of the scalar one and has the same optimum at every
    size: a solution ``p I`` of the scalar LMI gives one of the fleet's, and any solution ``P`` of
    the fleet's gives one of the scalar LMI, ``v^T P v`` for a unit vector ``v`` (the congruence
    with ``I_3 (x) v`` keeps the inequality). Solving one vehicle's block (:data:`BLOCK_STATES`)
    keeps the check that the optimal ``M`` is ``alpha I`` across its axes while its cost no longer
    grows with ``n`` (each solve at ``n = 20`` was a 120 x 120 LMI; a test compares the two sizes).

    Parameters
    ----------
    n : int
        Number of vehicles (checked, >= 2).
    """
    require_fleet_size(n)
    return BLOCK_STATES


def lmi_stabilizing_alpha(lam: float, gamma: float, n: int) -> LmiResult:
    """Stabilising solution of (37) as the extremal solution of a Riccati inequality.

    The problem is first normalised by ``sigma = sqrt(lam^2 + |c|)`` (1/s): with
    ``l = lam/sigma``, ``k = c/sigma^2`` and ``M = sigma L``, (37) reads
    ``k M^2 + 2 l M + I = 0`` with ``l^2 + |k| = 1``, and its stabilising root lies in
    ``[1/2, sqrt 2]`` whatever the scale of lambda and gamma. The quadratic term is put in
    Schur form with a ``sqrt|k|`` congruence, so no entry grows like ``1/|c|`` near
    ``gamma = 1/sqrt2``. By :func:`auv_hinf.design.theorem1.riccati_regime`:

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

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), ``>= 1/sqrt(lam^2 + 2)``.
    n : int
        Number of vehicles (>= 2); ``L`` is ``2n x 2n``, and the LMI is solved on one vehicle's
        block (:data:`BLOCK_STATES`), which has the same solution (see :func:`vehicle_block`).

    Raises
    ------
    DesignError
        If gamma is below ``1/sqrt(lam^2 + 2)``.
    SolverError
        If Clarabel does not return ``optimal`` or the LMI fails verification.
    """
    require_real_solution(lam, gamma)
    size = vehicle_block(n)
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

    Parameters
    ----------
    sys : control.StateSpace
        A continuous-time system, asymptotically stable.

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
    gains = (
        [float(np.linalg.norm(d, 2))]
        + [float(np.linalg.norm(c @ np.linalg.solve(1j * w * np.eye(nx) - a, b) + d, 2)) for w in freqs]
        if nx
        else [float(np.linalg.norm(d, 2))]
    )
    k = max(gains)
    if not k > 0.0 or not math.isfinite(k):
        k = 1.0

    def scaled(a0: FloatArray, b0: FloatArray, c0: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        mags = np.abs(poles)
        w0 = math.sqrt(float(mags.min() * mags.max()))
        a1, b1, c1 = a0 / w0, b0 / math.sqrt(w0), c0 / (math.sqrt(w0) * k)
        side = nx + max(nu, ny)
        big = np.zeros((side, side))
        big[:nx, :nx], big[:nx, nx : nx + nu], big[nx : nx + ny, :nx] = a1, b1, c1
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
    return LmiResult(
        value=k * g_val, status=cp.OPTIMAL, solves=total + solves, max_eig=max_eig, formulation="modal+balanced"
    )


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
    """Smallest alpha with ``||T||_inf <= gamma`` by bisection on BRL LMIs.

    Each step solves the BRL analysis LMI of the closed loop ``(lam - alpha) I`` on one
    vehicle's block (:func:`vehicle_block`: the fleet's ``2n``-state LMI has the same optimum)
    and compares the certified ``||T||`` with ``gamma``; the norm
    is decreasing in alpha, so bisection finds the boundary. Returns 0 when ``alpha = 0``
    already meets the bound.

    The problem is normalised by ``S = |lam| + 1/gamma`` (1/s): frequencies and gains are
    divided by ``S``, the bound becomes ``gamma S >= 1``, and the boundary pole
    ``beta = alpha - lam`` lies in ``(1/2, 1]`` in these units whatever the scale of lambda
    and gamma. The only LMI that could see a tiny pole is the one at ``alpha = 0``; it is
    skipped when the DC gain ``1/|lam|`` of that loop (a lower bound of its norm, evaluated
    with numpy) already exceeds gamma.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s), finite.
    gamma : float
        H-infinity bound (s), > 0.
    n : int
        Number of vehicles (>= 2); the closed loop has ``2n`` states.
    """
    lam_f = require_finite("lambda", lam)
    g = require_finite("gamma", gamma)
    if g <= 0:
        raise DesignError(f"gamma must be > 0, got {g!r}")
    size = vehicle_block(n)
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
    hi = bisect(lambda a: norm(a) > g_n, lo, hi, rtol=BISECTION_RTOL, atol=BISECTION_RTOL)[1]
    return LmiResult(value=hi * scale, status=cp.OPTIMAL, solves=solves, max_eig=max_eig, formulation=formulation)


__all__ = [
    "BLOCK_STATES",
    "MODAL_COND_MAX",
    "lmi_hinf_norm",
    "lmi_minimal_alpha",
    "lmi_stabilizing_alpha",
    "vehicle_block",
]
