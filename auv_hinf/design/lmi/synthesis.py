"""LMI synthesis of the position gains with an input bound on the invariant ellipsoid.

The perturbed position error loop of the robust certificate (per axis, ``P kron I2``) is

    x' = (A_o - l b K) x + b (w1 + w2 + d),   A_o = [[0, 1], [0, lam]],   K = [k1, alpha],

with ``|w1| <= sigma |x2|`` (the envelope's ``||D||``), ``|w2| <= delta |K x|`` (the spread
``delta`` of the input gain about its centre ``l``) and a unit disturbance ``|d| <= 1``. With
``Q = P^-1`` and ``Y = K Q`` (Boyd, El Ghaoui, Feron & Balakrishnan 1994, sections 5.2 and
7.2: quadratic stabilisation with norm-bounded uncertainty, invariant ellipsoids for bounded
disturbances, input constraints on the ellipsoid), ``{x^T P x <= 1}`` is invariant with
``V' <= -a (V - 1)`` when, for multipliers ``s1, s2 > 0`` (the inverses of the S-procedure's),

    [[A_o Q + Q A_o^T - l (b Y + Y^T b^T) + a Q + (s1 + s2 + 1/a) b b^T,  sigma Q e2,  delta Y^T],
     [sigma e2^T Q,                                                       -s1,         0        ],
     [delta Y,                                                             0,          -s2      ]]  < 0,

a linear matrix inequality in ``(Q, Y, s1, s2)`` for a fixed rate ``a`` (Schur complements of
the S-procedure terms ``t1 sigma^2 e2 e2^T``, ``t2 delta^2 K^T K`` and of the disturbance term
``P b b^T P / a``). On the ellipsoid the feedback ``|K x| <= sqrt(u)`` exactly when
``[[u, Y], [Y^T, Q]] >= 0``, and its velocity half-width is ``sqrt(Q_22)``. The SDP minimises
``u`` (the feedback acceleration per unit disturbance) with the velocity half-width capped.

The gains ``K = Y Q^-1`` are only a proposal: the robust certificate
(:func:`~auv_hinf.robust.certificate.robust_certificate`) certifies them from scratch, with its
own re-verified LMIs, so nothing here needs to be exact to be sound.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.design.lmi.core import solve
from auv_hinf.design.lmi.lyapunov import LYAP_STRICT_RTOL, strict_nsd_gap
from auv_hinf.exceptions import SolverError

_CP: Any = cp
_B = np.array([[0.0], [1.0]])
_E2 = np.array([[0.0], [1.0]])


@dataclass(frozen=True)
class PositionSynthesis:
    """A verified answer of the synthesis SDP.

    Attributes
    ----------
    k1, alpha : float
        The position gains (1/s^2, 1/s).
    feedback : float
        ``sup |K x|`` on the ellipsoid per unit disturbance (``sqrt(u)``, dimensionless).
    q : ndarray, shape (2, 2)
        ``Q = P^-1`` of the invariant ellipsoid (per unit disturbance).
    multipliers : tuple of float
        ``(s1, s2)``: the inverses of the S-procedure multipliers.
    rate : float
        The decay rate ``a`` (1/s).
    """

    k1: float
    alpha: float
    feedback: float
    q: FloatArray
    multipliers: tuple[float, float]
    rate: float


@lru_cache(maxsize=1)
def _synthesis_sdp() -> tuple[cp.Problem, dict[str, cp.Parameter], dict[str, cp.Variable]]:
    a_o = cp.Parameter((2, 2))
    gain, sigma, delta = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    rate, inv_rate, vcap = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    q = cp.Variable((2, 2), symmetric=True)
    y = cp.Variable((1, 2))
    s1, s2, u = cp.Variable(nonneg=True), cp.Variable(nonneg=True), cp.Variable(nonneg=True)
    bb = _B @ _B.T
    top = a_o @ q + q @ a_o.T - gain * (_B @ y + y.T @ _B.T) + rate * q + (s1 + s2 + inv_rate) * bb
    z = np.zeros((1, 1))
    m = _CP.bmat(
        [
            [top, sigma * (q @ _E2), delta * y.T],
            [sigma * (_E2.T @ q), -_CP.reshape(s1, (1, 1), order="C"), z],
            [delta * y, z, -_CP.reshape(s2, (1, 1), order="C")],
        ]
    )
    sym = 0.5 * (m + m.T)
    bound = _CP.bmat([[_CP.reshape(u, (1, 1), order="C"), y], [y.T, q]])  # |K x|^2 <= u on the ellipsoid
    cons = [
        sym << -LYAP_STRICT_RTOL * _CP.trace(q) * np.eye(4),
        q >> 0,
        0.5 * (bound + bound.T) >> 0,
        q[1, 1] <= vcap,
    ]
    prob = cp.Problem(cp.Minimize(u), cons)
    par = {"a_o": a_o, "gain": gain, "sigma": sigma, "delta": delta, "rate": rate, "inv_rate": inv_rate, "vcap": vcap}
    return prob, par, {"q": q, "y": y, "s1": s1, "s2": s2, "u": u}


def synthesis_matrix(
    q: FloatArray,
    y: FloatArray,
    s: tuple[float, float],
    a_o: FloatArray,
    gain: float,
    sigma: float,
    delta: float,
    rate: float,
) -> FloatArray:
    """The 4x4 synthesis LMI matrix (numpy), for the re-verification."""
    bb = _B @ _B.T
    top = a_o @ q + q @ a_o.T - gain * (_B @ y + y.T @ _B.T) + rate * q + (s[0] + s[1] + 1.0 / rate) * bb
    m = np.zeros((4, 4))
    m[:2, :2] = top
    m[:2, 2:3] = sigma * (q @ _E2)
    m[2:3, :2] = m[:2, 2:3].T
    m[:2, 3:4] = delta * y.T
    m[3:4, :2] = m[:2, 3:4].T
    m[2, 2], m[3, 3] = -s[0], -s[1]
    return m


def synthesise_position(
    lam: float, gain: float, sigma: float, delta: float, rate: float, velocity_cap: float
) -> PositionSynthesis | None:
    """Position gains of the SDP at ``rate`` (1/s), with the verified ellipsoid behind them.

    Parameters
    ----------
    lam : float
        Centre of the velocity loop's diagonal (1/s).
    gain : float
        Centre ``l`` of the input gain (dimensionless).
    sigma, delta : float
        Bounds of ``||D||`` (1/s) and of the input-gain spread (dimensionless).
    rate : float
        Decay rate ``a`` of ``V - 1`` (1/s).
    velocity_cap : float
        Largest squared velocity half-width per unit disturbance ((m/s)^2 per (m/s^2)^2).

    Returns
    -------
    PositionSynthesis or None
        ``None`` when the SDP is infeasible or its answer fails the ``eigvalsh`` re-check.
    """
    prob, par, var = _synthesis_sdp()
    a_o = np.array([[0.0, 1.0], [0.0, lam]])
    par["a_o"].value = a_o
    par["gain"].value, par["sigma"].value, par["delta"].value = gain, sigma, delta
    par["rate"].value, par["inv_rate"].value, par["vcap"].value = rate, 1.0 / rate, velocity_cap
    try:
        solve(prob, "position-gain synthesis LMI")
    except SolverError:
        return None
    q = np.asarray(var["q"].value, dtype=float)
    q = 0.5 * (q + q.T)
    y = np.asarray(var["y"].value, dtype=float).reshape(1, 2)
    s = (float(var["s1"].value), float(var["s2"].value))
    gap, margin = strict_nsd_gap(synthesis_matrix(q, y, s, a_o, gain, sigma, delta, rate))
    pgap, pmargin = strict_nsd_gap(-q)
    if gap >= -margin or pgap >= -pmargin:
        return None
    k = (y @ np.linalg.inv(q)).ravel()
    if not (k[0] > 0.0 and np.all(np.isfinite(k))):
        return None
    feedback = float(np.sqrt(max(float(var["u"].value), 0.0)))
    return PositionSynthesis(float(k[0]), float(k[1]), feedback, q, s, rate)


__all__ = ["PositionSynthesis", "synthesis_matrix", "synthesise_position"]
