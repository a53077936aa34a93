"""python-control models of the per-block closed loops and their H-infinity norms.

:func:`hinf_norm` is python-control's ``control.norm(sys, 'inf')`` (SLICOT ``ab13dd`` when
slycot is installed, a Hamiltonian bisection otherwise). :func:`hinf_norm_peak` returns the
norm *and* the frequency where it is attained, like MATLAB's ``hinfnorm``, with the
two-step Hamiltonian algorithm of Bruinsma and Steinbuch (1990) written in numpy.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg as sla

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import DesignError, SolverError

#: control.norm(sys, 'inf') without slycot bisects on Hamiltonian eigenvalues (~1e-6
#: relative); with slycot (ab13dd) it is ~1e-10. 1e-5 is the honest agreement of either.
NORM_RTOL = 1e-5

#: Relative gap at which :func:`hinf_norm_peak` stops: the returned norm is a value
#: ``sigma_max(G(j w_peak))`` (a lower bound) within this factor of the true norm.
PEAK_RTOL = 1e-10

#: An eigenvalue ``e`` of the Hamiltonian ``H`` counts as imaginary when
#: ``|Re e| <= IMAG_AXIS_RTOL * ||H||_1``. Round-off moves eigenvalues by ~eps ||H||, and
#: near a tangency (two crossings about to merge) by ~sqrt(eps) ||H||: 1e-8 covers both, so
#: no crossing is missed even on stiff systems (poles 1e-3 .. 1e8). A spurious "crossing"
#: only adds an evaluation point, never a wrong value: the returned norm is always a
#: computed ``sigma_max(G(j w))``.
IMAG_AXIS_RTOL = 1e-8

#: Log-spaced frequencies (between the smallest and largest pole magnitude) evaluated to
#: seed the lower bound, besides 0, infinity and the pole magnitudes.
SEED_POINTS = 64

#: Safety cap on the Bruinsma-Steinbuch iterations (quadratic convergence: ~5 suffice).
PEAK_MAX_ITER = 60


def velocity_block(lam: float, alpha: float, dim: int = 2) -> ct.StateSpace:
    """Closed velocity loop ``Ze' = (lam - alpha) Ze + w``, output ``Ze`` (one block: dim 2).

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    alpha : float
        Velocity gain (1/s).
    dim : int
        Number of channels (states, inputs and outputs).
    """
    eye = np.eye(dim)
    return ct.ss((lam - alpha) * eye, eye, eye, np.zeros((dim, dim)), name="velocity_block")


def position_block(lam: float, alpha: float, k1: float, dim: int = 2) -> ct.StateSpace:
    """Theorem 2 loop ``[Xe; Ze]' = [[0, I], [-k1 I, (lam - alpha) I]] [Xe; Ze] + [0; I] w``.

    Output ``Ze``; one block has ``dim = 2``.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    dim : int
        Number of channels (``2 dim`` states).
    """
    eye, zero = np.eye(dim), np.zeros((dim, dim))
    a = np.block([[zero, eye], [-k1 * eye, (lam - alpha) * eye]])
    b = np.vstack([zero, eye])
    c = np.hstack([zero, eye])
    return ct.ss(a, b, c, zero, name="position_block")


def hinf_norm(sys: ct.StateSpace) -> float:
    """H-infinity norm from ``control.norm(sys, 'inf')`` (s for the loops here).

    Any warning it emits is an error; any failure of the back end is raised as
    :class:`~auv_hinf.exceptions.SolverError`.

    Parameters
    ----------
    sys : control.StateSpace
        A stable continuous-time system.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            value = float(ct.norm(sys, "inf"))
    except (ArithmeticError, ValueError, RuntimeError, Warning) as exc:
        raise SolverError(f"control.norm(sys, 'inf') failed: {exc}") from exc
    if not math.isfinite(value):
        raise SolverError(f"control.norm(sys, 'inf') returned {value!r} (system not stable?)")
    return value


@dataclass(frozen=True)
class HinfPeak:
    """H-infinity norm and where it is reached.

    Attributes
    ----------
    norm : float
        ``sup_w sigma_max(G(j w))``, in the units of the system's gain.
    omega_peak : float
        A frequency (rad/s) with ``sigma_max(G(j omega_peak)) = norm``; ``inf`` when the
        supremum is only approached as ``w -> inf`` (the feedthrough ``D`` dominates).
    upper : float
        Upper bound ``(1 + 2 rtol) norm``: the Hamiltonian test found no crossing at this
        level (or no improvement at any crossing and midpoint).
    iterations : int
        Bruinsma-Steinbuch iterations used.
    """

    norm: float
    omega_peak: float
    upper: float
    iterations: int


def _sigma_max(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray, w: float) -> float:
    if math.isinf(w):
        return float(np.linalg.norm(d, 2))
    g = c @ np.linalg.solve(1j * w * np.eye(a.shape[0]) - a, b) + d
    return float(np.linalg.norm(g, 2))


def hinf_norm_peak(sys: ct.StateSpace, *, rtol: float = PEAK_RTOL) -> HinfPeak:
    """H-infinity norm and peak frequency of a stable continuous-time ``StateSpace``.

    Bruinsma-Steinbuch: start from the best of ``sigma_max(G(jw))`` at ``w = 0``, ``inf`` and
    the pole magnitudes and imaginary parts; at the level ``g = (1 + 2 rtol) * best`` find
    the imaginary eigenvalues ``j w_i`` of the Hamiltonian

    ``H = [[A + B R^-1 D^T C, B R^-1 B^T], [-C^T (I + D R^-1 D^T) C, -(A + B R^-1 D^T C)^T]]``,
    ``R = g^2 I - D^T D`` (``g`` is a singular value of ``G(jw)`` iff ``jw`` is one), and
    evaluate ``G`` at the midpoints of consecutive ``w_i``; stop when there is none. The
    states are first balanced (``scipy.linalg.matrix_balance``; the norm is invariant under
    a state similarity).

    Parameters
    ----------
    sys : control.StateSpace
        Continuous-time, asymptotically stable.
    rtol : float
        Relative accuracy of the returned norm.

    Returns
    -------
    HinfPeak
        ``norm`` is attained at ``omega_peak``: ``norm <= ||G||_inf <= upper``.

    Raises
    ------
    DesignError
        If the system is not continuous-time or not asymptotically stable.
    SolverError
        If the iteration does not converge.

    Examples
    --------
    >>> import control as ct
    >>> p = hinf_norm_peak(ct.ss(ct.tf([1.0, 0.0], [1.0, 0.5, 4.0])))
    >>> round(p.norm, 9), round(p.omega_peak, 9)
    (2.0, 2.0)
    """
    if not sys.isctime():
        raise DesignError("hinf_norm_peak needs a continuous-time system")
    a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    nx = a.shape[0]
    if nx == 0:
        value = float(np.linalg.norm(d, 2))
        return HinfPeak(norm=value, omega_peak=math.inf, upper=value, iterations=0)
    poles = np.linalg.eigvals(a)
    if np.any(poles.real >= 0):
        raise DesignError(f"hinf_norm_peak needs an asymptotically stable system; poles {poles}")
    _, (scale, _) = sla.matrix_balance(a, permute=False, separate=True)
    t = np.asarray(scale, dtype=float)
    a, b, c = a * t[None, :] / t[:, None], b / t[:, None], c * t[None, :]
    mags = np.abs(poles)
    seeds = np.logspace(math.log10(mags.min()), math.log10(mags.max()), SEED_POINTS)
    candidates = [0.0, math.inf, *mags.tolist(), *np.abs(poles.imag).tolist(), *seeds.tolist()]
    best, w_best = -1.0, 0.0
    for w in candidates:
        val = _sigma_max(a, b, c, d, w)
        if val > best:
            best, w_best = val, w
    if best <= 0.0:
        return HinfPeak(norm=0.0, omega_peak=0.0, upper=0.0, iterations=0)
    nu, ny = b.shape[1], c.shape[0]
    for it in range(1, PEAK_MAX_ITER + 1):
        g = (1.0 + 2.0 * rtol) * best
        r = g * g * np.eye(nu) - d.T @ d
        r_inv_dt = np.linalg.solve(r, d.T)
        a_h = a + b @ r_inv_dt @ c
        ham = np.block(
            [
                [a_h, b @ np.linalg.solve(r, b.T)],
                [-c.T @ (np.eye(ny) + d @ r_inv_dt) @ c, -a_h.T],
            ]
        )
        eig = np.linalg.eigvals(ham)
        on_axis = np.abs(eig.real) <= IMAG_AXIS_RTOL * float(np.abs(ham).sum(axis=0).max())
        omegas = np.unique(np.round(np.sort(np.abs(eig[on_axis].imag)), 14))
        if omegas.size == 0:
            return HinfPeak(norm=best, omega_peak=w_best, upper=g, iterations=it)
        improved = False
        for w in np.concatenate([omegas, 0.5 * (omegas[:-1] + omegas[1:])]):
            val = _sigma_max(a, b, c, d, float(w))
            if val > best:
                best, w_best, improved = val, float(w), True
        if not improved:
            return HinfPeak(norm=best, omega_peak=w_best, upper=g, iterations=it)
    raise SolverError(f"hinf_norm_peak did not converge in {PEAK_MAX_ITER} iterations")


__all__ = [
    "IMAG_AXIS_RTOL",
    "NORM_RTOL",
    "PEAK_MAX_ITER",
    "PEAK_RTOL",
    "SEED_POINTS",
    "HinfPeak",
    "hinf_norm",
    "hinf_norm_peak",
    "position_block",
    "velocity_block",
]
