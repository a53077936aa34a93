"""Clarabel solves with status checks and retries, and the numpy re-verification of LMIs."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import SolverError

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

    Parameters
    ----------
    problem : cvxpy.Problem
        The problem to solve (in place: its variables hold the solution afterwards).
    what : str
        Name of the computation, for the error message.
    """
    solves = 0
    status: str | None = None
    failure: Exception | None = None
    for settings in ({}, *_RETRY_SETTINGS):
        solves += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                # warm_start=False: cvxpy would otherwise reuse the cached problem's Clarabel solver,
                # whose settings start from the last solve's (a retry's settings would stick) and
                # whose answers then depend on what the process solved before
                problem.solve(solver=cp.CLARABEL, warm_start=False, **settings)
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
    """Check that a numeric symmetric matrix is negative semidefinite; return its max eig.

    Parameters
    ----------
    matrix : ndarray, shape (n, n)
        The LMI matrix evaluated at the solution; its symmetric part is checked.
    what : str
        Name of the LMI, for the error message.

    Raises
    ------
    SolverError
        If the largest eigenvalue exceeds ``LMI_VERIFY_TOL * max(1, max |entry|)``.
    """
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


#: Strictness imposed inside the SDPs: ``LMI <= -LYAP_STRICT_RTOL * trace(P) I``. Clarabel
#: meets its constraints to about 1e-8 relative, so a margin ten times larger survives the
#: solver's round-off and the eigenvalue re-check below sees a strictly negative matrix.
LYAP_STRICT_RTOL = 1e-7


def roundoff_margin(size: int, scale: float) -> float:
    """Eigenvalue round-off allowance ``EIG_ROUNDOFF_FACTOR * n * eps * scale``.

    Parameters
    ----------
    size : int
        Matrix dimension ``n``.
    scale : float
        Size of the matrix entries (floored at 1e-300), in the matrix's unit.
    """
    return EIG_ROUNDOFF_FACTOR * size * float(np.finfo(float).eps) * max(scale, 1e-300)


def strict_nsd_gap(matrix: FloatArray, scale: float = 0.0) -> tuple[float, float]:
    """Largest eigenvalue of the symmetric part of ``matrix`` and the round-off margin.

    The matrix is *strictly* negative definite, provably and despite round-off, when the
    first value is below minus the second.

    Parameters
    ----------
    matrix : ndarray, shape (n, n)
        The assembled LMI matrix.
    scale : float
        Size of the terms ``matrix`` was assembled from; the margin uses the larger of it and
        the spectral norm of the symmetric part (the default 0 uses that norm alone).
    """
    sym = 0.5 * (matrix + matrix.T)
    eigs = np.linalg.eigvalsh(sym)
    norm = float(np.abs(eigs).max())
    return float(eigs.max()), roundoff_margin(sym.shape[0], max(norm, scale))


#: Multiple of ``n * eps * scale`` a verified eigenvalue must clear. ``eigvalsh`` is
#: backward stable (error <= a small multiple of ``n eps ||M||``) and assembling ``M`` from
#: its terms adds a few ulps of the largest term, both covered by this factor.
EIG_ROUNDOFF_FACTOR = 64.0


__all__ = [
    "BISECTION_RTOL",
    "EIG_ROUNDOFF_FACTOR",
    "LMI_MARGIN",
    "LMI_RTOL",
    "LMI_VERIFY_TOL",
    "LYAP_STRICT_RTOL",
    "LmiResult",
    "roundoff_margin",
    "solve",
    "strict_nsd_gap",
    "verify_nsd",
]
