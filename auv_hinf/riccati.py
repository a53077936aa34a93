"""Riccati solves of eq. (37) on the full ``2N x 2N`` problem (python-control and scipy).

Eq. (37), ``A^T L + L A + c L^2 + I = 0`` with ``A = lam I`` and ``c = 1/gamma^2 - 2``, maps to
``care``'s form ``A^T X + X A - X B R^-1 B^T X + Q = 0`` with ``B = Q = I`` and ``R = -(1/c) I``:

* ``gamma > 1/sqrt2`` (``c < 0``): ``R`` is positive definite, the usual LQR-type ARE;
* ``gamma < 1/sqrt2`` (``c > 0``): ``R`` is *negative* definite. Both ``control.care`` and
  ``scipy.linalg.solve_continuous_are`` accept it (they work on the Hamiltonian pencil, whose
  eigenvalues ``+-s`` stay real and split) and return the stabilising root ``lam + c L = -s I``,
  not the paper's '+' root;
* ``gamma = 1/sqrt2`` (``c = 0``): ``R`` would be infinite; (37) is the Lyapunov equation
  ``2 lam L + I = 0``, solved with ``control.lyap`` / scipy's Lyapunov solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg as sla

from ._typing import RiccatiSolver
from .design import GAMMA_SINGULAR_TOL, riccati_c, theorem1_conditions
from .exceptions import DesignError, require_fleet_size

#: Riccati solvers agree with the closed form to round-off of a 2N-dimensional QZ/Schur.
ARE_RTOL = 1e-9


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


def require_real_solution(lam: float, gamma: float) -> None:
    """Raise :class:`DesignError` when eq. (37) has no real root (gamma below the bound)."""
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
        Bound with ``gamma >= 1/sqrt(lam^2+2)``.
    n : int
        Number of vehicles; the problem has size ``2n``.
    solver : {"control", "scipy"}
    """
    require_real_solution(lam, gamma)
    size = 2 * require_fleet_size(n)
    a = lam * np.eye(size)
    eye = np.eye(size)
    c = riccati_c(gamma)
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
    c = riccati_c(gamma)
    s = math.sqrt(max(lam * lam - c, 0.0))
    return min(ROOT_CONDITION_CAP, 1.0 + abs(lam) / s) if s > 0 else ROOT_CONDITION_CAP


