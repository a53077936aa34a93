"""Riccati solves of eq. (37) on the full ``2N x 2N`` problem (python-control and scipy).

Eq. (37), ``A^T L + L A + c L^2 + I = 0`` with ``A = lam I`` and ``c = 1/gamma^2 - 2``, maps to
``care``'s form ``A^T X + X A - X B R^-1 B^T X + Q = 0`` with ``B = Q = I`` and ``R = -(1/c) I``.
The branch is :func:`auv_hinf.design.theorem1.riccati_regime`:

* ``"R>0"`` (``c < 0``, gamma > 1/sqrt2): the usual LQR-type ARE;
* ``"R<0"`` (``c > 0``, gamma < 1/sqrt2): ``R`` is *negative* definite. Both ``control.care``
  and ``scipy.linalg.solve_continuous_are`` accept it (they work on the Hamiltonian pencil,
  whose eigenvalues ``+-s`` stay real and split) and return the stabilising root
  ``lam + c L = -s I``, not the paper's '+' root;
* ``"lyapunov"`` (``|c|`` negligible next to ``lam^2``): ``R`` would be (nearly) infinite; (37)
  is the Lyapunov equation ``2 lam L + I = 0``, solved with ``control.lyap`` / scipy;
* ``"double-root"`` (discriminant ``lam^2 - c`` zero up to round-off, gamma = gamma_min): the
  Hamiltonian has a double eigenvalue at 0, no solver can split it, and the root is the
  closed form ``L = (-lam - sqrt(max(disc, 0)))/c I`` of the merged pair (solver
  ``"closed-form"``). The report records this, so the comparison is not counted as an
  independent solve.

Solver failures (``LinAlgError``, python-control or slycot errors) are raised as
:class:`~auv_hinf.exceptions.SolverError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg as sla

from auv_hinf._typing import RiccatiSolver
from auv_hinf.design.theorem1 import discriminant, riccati_c, riccati_regime, theorem1_conditions
from auv_hinf.exceptions import DesignError, SolverError, require_fleet_size

#: Relative agreement of the Riccati solvers with the closed form: round-off of a
#: 2N-dimensional QZ/Schur is ~1e-15 relative to alpha; 1e-9 leaves room for the
#: conditioning near gamma_min, which the cross-check multiplies in (:func:`root_condition`).
ARE_RTOL = 1e-9

#: Exceptions a solver back end raises on failure; they are re-raised as SolverError.
_SOLVER_FAILURES: tuple[type[BaseException], ...] = (
    np.linalg.LinAlgError,
    ArithmeticError,
    ct.ControlArgument,
    ValueError,
    RuntimeError,
)


@dataclass(frozen=True)
class RiccatiResult:
    """Solution of eq. (37) by one solver.

    Attributes
    ----------
    solver : str
        ``"control.care"``, ``"scipy.care"``, ``"control.lyap"``, ``"scipy.lyap"`` or
        ``"closed-form"`` (double root).
    regime : str
        :func:`auv_hinf.design.theorem1.riccati_regime`: ``"R>0"``, ``"R<0"``, ``"lyapunov"`` or
        ``"double-root"``.
    alpha : float
        ``trace(L)/(2N)``, 1/s.
    structure_error : float
        ``max |L - alpha I|`` (1/s): how far L is from a multiple of the identity.
    residual : float
        Max absolute entry of the left side of (37) at L (dimensionless: the constant term
        of (37) is ``I``, so this is already relative to the equation's scale).
    """

    solver: str
    regime: str
    alpha: float
    structure_error: float
    residual: float


def require_real_solution(lam: float, gamma: float) -> None:
    """Raise :class:`DesignError` when eq. (37) has no real root (gamma below the bound).

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), > 0.
    """
    cond = theorem1_conditions(lam, gamma)
    if not cond.gamma_ok:
        raise DesignError(f"gamma={gamma:.6g} below 1/sqrt(lambda^2+2)={cond.gamma_min:.6g}: (37) has no real solution")


def riccati_alpha(lam: float, gamma: float, n: int, *, solver: RiccatiSolver = "control") -> RiccatiResult:
    """Solve eq. (37) for ``L`` (``2n x 2n``) with ``control`` or ``scipy``.

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        Bound with ``gamma >= 1/sqrt(lam^2+2)`` (s).
    n : int
        Number of vehicles; the problem has size ``2n``.
    solver : {"control", "scipy"}

    Raises
    ------
    DesignError
        If gamma is below the bound (no real root) or ``solver`` is unknown.
    SolverError
        If the back end fails or returns a non-finite matrix.
    """
    require_real_solution(lam, gamma)
    if solver not in ("control", "scipy"):
        raise DesignError(f"Riccati solver must be 'control' or 'scipy', got {solver!r}")
    size = 2 * require_fleet_size(n)
    a = lam * np.eye(size)
    eye = np.eye(size)
    c = riccati_c(gamma)
    regime = riccati_regime(lam, gamma)
    try:
        if regime == "double-root":
            # Merged roots: (c L + lam I)^2 = disc I with disc ~ 0, so c L = -(lam + sqrt(disc)) I.
            # c > 0 here (c = lam^2 > 0), and -lam - sqrt(disc) has no cancellation.
            x = (-(lam + math.sqrt(max(discriminant(lam, gamma), 0.0))) / c) * eye
            name = "closed-form"
        elif regime == "lyapunov":
            if solver == "control":
                x = ct.lyap(a, eye)  # A X + X A^T + Q = 0
            else:
                x = sla.solve_continuous_lyapunov(a, -eye)  # A X + X A^H = Q
            name = f"{solver}.lyap"
        else:
            r = (-1.0 / c) * eye
            if solver == "control":
                x, _, _ = ct.care(a, eye, eye, r)
            else:
                x = sla.solve_continuous_are(a, eye, eye, r)
            name = f"{solver}.care"
    except _SOLVER_FAILURES as exc:
        raise SolverError(
            f"{solver} Riccati solve of eq. (37) failed (regime {regime}, lambda={lam!r}, gamma={gamma!r}): {exc}"
        ) from exc
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)):
        raise SolverError(f"{solver} Riccati solve of eq. (37) returned a non-finite matrix (regime {regime})")
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

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), nonzero.
    """
    c = riccati_c(gamma)
    s = math.sqrt(max(lam * lam - c, 0.0))
    return min(ROOT_CONDITION_CAP, 1.0 + abs(lam) / s) if s > 0 else ROOT_CONDITION_CAP


__all__ = [
    "ARE_RTOL",
    "ROOT_CONDITION_CAP",
    "RiccatiResult",
    "require_real_solution",
    "riccati_alpha",
    "root_condition",
]
