"""Robust design by LMI synthesis: the gains that need the least force, certified for the box.

The bandwidth family (:mod:`auv_hinf.robust.bandwidth`) fixes the shape of the gains and
searches one number. Here the position gains ``(k1, alpha)`` come from the synthesis LMI of
:func:`synthesise_position` (below): for a decay rate ``a`` and a cap on the velocity error
it minimises the feedback acceleration on the invariant ellipsoid, over every plant of the box
(the vertex sigma and the input-gain spread) and the current's disturbance. The heading gains
follow by pole placement at :data:`~auv_hinf.robust.bandwidth.HEADING_RATIO` times the position
loop's natural frequency ``sqrt(l k1)``.

The objective, stated in every design: the smallest **certified peak force** relative to the
actuator limits (or in newtons when none are declared), among the candidates whose robust
certificate covers the box scaled by :data:`~auv_hinf.robust.bandwidth.TARGET_MARGIN` (else by
1). The search runs over :data:`RATES` (fractions of ``|lam| + sigma``) and :data:`VELOCITY_SHARES`
(the share of the envelope's sway half-width the velocity error may take). Every candidate is
certified from scratch by :func:`~auv_hinf.robust.invariant_set.robust_certificate`; the SDP
only proposes.

The synthesis LMI. The perturbed position error loop of the robust certificate (per axis, ``P kron I2``) is

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
(:func:`~auv_hinf.robust.invariant_set.robust_certificate`) certifies them from scratch, with its
own re-verified LMIs, so nothing here needs to be exact to be sound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np
from tqdm.auto import tqdm

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import Actuators
from auv_hinf.exceptions import SolverError
from auv_hinf.law.gains import Gains, heading_gains, with_integral
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import ErrorBounds, inflate_envelope, operating_envelope
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.lmi import LYAP_STRICT_RTOL, solve, strict_nsd_gap
from auv_hinf.robust.bandwidth import HEADING_RATIO, TARGET_MARGIN, RobustDesign
from auv_hinf.robust.box import ParameterBox, TubeSummary, box_lambda, position_disturbance
from auv_hinf.robust.invariant_set import OPERATING_WIDEN, RobustCertificate, robust_certificate

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
    """The 4x4 synthesis LMI matrix (numpy), for the re-verification.

    Parameters
    ----------
    q : ndarray, shape (2, 2)
        ``Q = P^-1``.
    y : ndarray, shape (1, 2)
        ``Y = K Q``.
    s : tuple of float
        ``(s1, s2)``, the inverses of the S-procedure multipliers.
    a_o : ndarray, shape (2, 2)
        ``A_o = [[0, 1], [0, lam]]``.
    gain : float
        Centre ``l`` of the input gain (dimensionless).
    sigma : float
        Bound of ``||D||`` (1/s).
    delta : float
        Spread of the input gain about ``l`` (dimensionless).
    rate : float
        Decay rate ``a`` (1/s), > 0.
    """
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


#: Decay rates tried, as fractions of ``|lam| + sigma`` (1/s).
RATES = (0.05, 0.15, 0.4, 1.0)


#: Shares of the envelope's sway half-width that the certified velocity error may take.
VELOCITY_SHARES = (0.3, 0.6, 0.9)


#: Smallest disturbance bound used to size the velocity cap (m/s^2): a plant known exactly in
#: still water has none, and any positive floor far below real disturbances keeps the cap finite.
DISTURBANCE_FLOOR = 1e-12


#: Largest velocity cap ((m/s)^2 per (m/s^2)^2, a velocity half-width of 100 s times the disturbance):
#: with no disturbance the cap is not a constraint, and above about 1e6 Clarabel fails on the SDP
#: (it panics when the box is empty too). Every candidate is certified afterwards, so the cap only
#: narrows the search.
VELOCITY_CAP_MAX = 1e4


OBJECTIVE = "minimise the certified peak force (relative to the actuator limits when declared)"


def _score(cert: RobustCertificate, actuators: Actuators | None) -> float:
    """Objective value of a covering certificate: largest peak/limit ratio, or largest force (N)."""
    if cert.thrust is None:
        return math.inf
    peak = cert.thrust.as_tuple()
    if actuators is not None:
        return actuators.utilisation(peak)
    return max(peak[0], peak[1])


def _proposals(
    box: ParameterBox, env: Envelope, summ: TubeSummary, current: float, velocity: float, integral: bool
) -> list[tuple[Gains, float]]:
    """The gains the synthesis SDP proposes at each of :data:`RATES`, the plant's spread taken over ``env``.

    Each comes with its position loop's natural frequency ``sqrt(l k1)`` (rad/s); ``velocity`` caps
    the velocity error's half-width (m/s) on the invariant ellipsoid.
    """
    lc, spread = box.input_gain()
    lam, sigma = box_lambda(box, env)
    scale = abs(lam) + sigma
    # the disturbance of the position loop at zero heading error; the heading coupling is
    # checked afterwards by the robust certificate of each candidate
    dbar = max(position_disturbance(box, env, summ, current, 0.0, lam, sigma), DISTURBANCE_FLOOR)
    cap = min((velocity / dbar) ** 2, VELOCITY_CAP_MAX)
    out = []
    for frac in RATES:
        found = synthesise_position(lam, lc, sigma, spread, frac * scale, cap)
        if found is None:
            continue
        h = HEADING_RATIO * math.sqrt(lc * found.k1)
        gains = Gains(found.alpha, found.k1, heading_gains(box.nominal, (-h, -1.5 * h)))
        out.append((with_integral(gains, lam, lc) if integral else gains, math.sqrt(lc * found.k1)))
    return out


def synthesise_robust(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    current: float = 0.0,
    actuators: Actuators | None = None,
    *,
    progress: bool = False,
    integral: bool = False,
) -> RobustDesign:
    """The synthesised robust design (see the module docstring).

    Parameters
    ----------
    box : ParameterBox
        The declared plant box.
    envelope : Envelope
        Operating envelope.
    tube : ReferenceTube
        Bounds of the desired motion.
    current : float
        Declared current speed (m/s), scaled with the box.
    actuators : Actuators, optional
        The force limits; the objective is then relative to them.
    progress : bool
        Show a progress bar over the candidates.
    integral : bool
        Give every candidate the integral gain of :func:`~auv_hinf.law.gains.integral_gain` for
        its ``(alpha, k1)`` before it is certified.

    Returns
    -------
    RobustDesign
        Its ``bandwidth`` is the position loop's natural frequency ``sqrt(l k1)`` (rad/s) and
        ``target`` the box scale it covers (``TARGET_MARGIN``, 1, or 0 when no candidate covers:
        then the candidate with the best objective on the declared box, not certified).
    """
    lc = box.input_gain()[0]
    summ = TubeSummary.of(tube)
    half_v = min(-envelope.v[0], envelope.v[1])
    candidates: list[tuple[Gains, float]] = []
    # the plant's spread and the disturbance over the declared envelope, and over the velocities
    # a vehicle whose velocity error is the share's cap can reach (the robust certificate refines
    # its own envelope the same way, :func:`~auv_hinf.robust.invariant_set.robust_certificate`)
    for share in VELOCITY_SHARES:
        for reach in (None, ErrorBounds(0.0, share * half_v + current, 0.0, share * half_v)):
            env = envelope if reach is None else operating_envelope(tube, reach, envelope, OPERATING_WIDEN)
            candidates += _proposals(box, inflate_envelope(env), summ, current, share * half_v, integral)
    tried: list[tuple[float, float, bool]] = []
    best: tuple[float, int, float] | None = None  # (score, candidate, box scale)
    cap_scale = box.max_scale if box.declared else math.inf
    declared: dict[int, RobustCertificate] = {}  # each candidate's certificate on the declared box, once

    def on_declared(k: int) -> RobustCertificate:
        if k not in declared:
            declared[k] = robust_certificate(box, envelope, tube, candidates[k][0], current, actuators)
        return declared[k]

    def consider(k: int, target: float, cert: RobustCertificate) -> bool:
        nonlocal best
        tried.append((candidates[k][1], target, cert.covers))
        if cert.covers:
            score = _score(cert, actuators) / (1.0 + 1e-9 * target)  # prefer the larger target on ties
            if best is None or (target, -score) > (best[2], -best[0]):
                best = (score, k, target)
        return cert.covers

    big = TARGET_MARGIN if TARGET_MARGIN <= cap_scale else None
    with tqdm(total=len(candidates), disable=not progress, desc="LMI synthesis", unit="candidate") as bar:
        for k, (gains, _) in enumerate(candidates):
            bar.update(1)
            # the declared box first while no candidate covers the larger one: a candidate that
            # does not cover the declared box is not tried on the larger (this only orders the
            # search; every answer is certified)
            if (best is None or best[2] < TARGET_MARGIN) and not consider(k, 1.0, on_declared(k)):
                continue
            if big is not None:
                b = box.scaled(big) if box.declared else box
                consider(k, big, robust_certificate(b, envelope, tube, gains, current * big, actuators))
    if best is None:
        # nothing covers: show the candidate with the best objective on the declared box
        rated = [(g, w, on_declared(k)) for k, (g, w) in enumerate(candidates)]
        if not rated:
            lam, _ = box_lambda(box, inflate_envelope(envelope))
            gains = Gains(-lam / lc + 1.0, 1.0, heading_gains(box.nominal, (-1.0, -1.5)))
            gains = with_integral(gains, lam, lc) if integral else gains
            cert = robust_certificate(box, envelope, tube, gains, current, actuators)
            return RobustDesign(
                gains,
                1.0,
                0.0,
                cert,
                tuple(tried),
                "no synthesis LMI gave verified gains at any rate (infeasible, or the solver failed)",
            )
        k = int(np.argmin([_score(c, None) if c.thrust is not None else math.inf for _, _, c in rated]))
        g, w, cert = rated[k]
        why = "no synthesised candidate covers the declared box; showing the one needing the least force"
        return RobustDesign(g, w, 0.0, cert, tuple(tried), why)
    score, k, target = best
    gains, w = candidates[k]
    cert = on_declared(k)
    unit = "of the actuator limits" if actuators is not None else "N"
    why = (
        f"LMI synthesis ({len(candidates)} candidates): {OBJECTIVE}; best {score:.4g} {unit} "
        f"among those covering the box scaled by {target:g}"
    )
    return RobustDesign(gains, w, target, cert, tuple(tried), why)


__all__ = [
    "DISTURBANCE_FLOOR",
    "OBJECTIVE",
    "RATES",
    "VELOCITY_CAP_MAX",
    "VELOCITY_SHARES",
    "PositionSynthesis",
    "synthesis_matrix",
    "synthesise_position",
    "synthesise_robust",
]
