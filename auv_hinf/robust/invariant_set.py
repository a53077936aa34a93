"""The robust certificate: every plant of a declared box, every current up to a declared speed.

For each vehicle the perturbed position and heading error loops of :mod:`auv_hinf.robust.box`
get verified invariant ellipsoids. They are coupled: the position disturbance grows with the
heading error (through ``sin theta``) and the heading disturbance with the velocity error
(through ``u v``). The certificate assumes bounds ``(E_psi, E_v)``, computes the ellipsoids
those assumptions allow, and accepts when the ellipsoids are strictly inside the assumptions:
by continuity a trajectory that starts inside both ellipsoids can never be the first to
violate an assumption (the first-exit argument of :mod:`auv_hinf.closed_loop.region`, with
sigma on the envelope inflated by 1e-9). The assumptions come from the least fixed point of
that map, inflated slightly.

What is certified, per vehicle and for every plant in the box and every constant current with
``|c| <= current``: a start inside both ellipsoids keeps its errors within ``bounds`` for all
``t >= 0``; ``V - 1`` decays at least as ``exp(-2 decay_rate t)``; the body velocities stay in
the envelope (``margins``) and the thrust within ``thrust``.

The ellipsoid LMIs. Both loops are 2-state (the position loop acts on ``(e, e')`` through
``P kron I2``) with a unit-bounded disturbance ``|d| <= 1``; the real bound scales the
ellipsoid linearly. A matrix ``P > 0`` with ``V' <= -a (V - 1)`` for every admissible
uncertainty makes ``{V <= l}`` invariant for every ``l >= 1`` and gives
``V(t) - 1 <= (V(0) - 1) exp(-a t)``.

* position: ``x' = A0 x + b (w1 + w2 + d)`` with ``|w1| <= sigma |x2|`` and
  ``|w2| <= delta |k1 x1 + alpha x2|`` (S-procedure, multipliers ``tau1, tau2``);
* heading: ``x' = A(K, C) x + b d`` for every ``(K, C)`` in a box; ``A`` is affine in
  ``(K, C)``, so the LMI at the four vertices holds on the whole box and for time-varying
  ``K(t), C(t)``.

For a fixed rate ``a`` the SDP minimises ``ext_1^2 + w ext_2^2`` (the squared half-widths of
the ellipsoid along the two states, through Schur complements); :func:`best_ellipsoid`
searches ``a``. Every answer is re-verified with ``eigvalsh`` beyond a round-off margin.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import cvxpy as cp
import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import Actuators, actuator_shortfall
from auv_hinf.actuation.thrust import ThrustBounds, ellipsoid_feedback, thrust_bounds
from auv_hinf.exceptions import AuvHinfError, SolverError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import (
    MAX_HEADING_ERROR,
    ErrorBounds,
    Margins,
    envelope_margins,
    inflate_envelope,
    operating_envelope,
)
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.lmi import LYAP_STRICT_RTOL, solve, strict_nsd_gap
from auv_hinf.numerics.quadratic_forms import pair_level
from auv_hinf.robust.box import (
    HeadingPerturbation,
    ParameterBox,
    TubeSummary,
    box_lambda,
    current_offset,
    heading_perturbation,
    position_disturbance,
)

_CP: Any = cp


_B = np.array([[0.0], [1.0]])


#: Rates tried by the coarse search, as fractions of the nominal loop's largest admissible rate.
RATE_GRID = tuple(float(x) for x in np.geomspace(1e-3, 0.98, 10))


#: Golden-section refinements of the rate after the coarse grid.
RATE_REFINEMENTS = 5


@dataclass(frozen=True)
class Ellipsoid:
    """A verified invariant ellipsoid ``{x^T P x <= 1}`` of a unit-disturbance loop.

    Attributes
    ----------
    matrix : ndarray, shape (2, 2)
        ``P`` (positive definite).
    rate : float
        ``a`` (1/s): ``V - 1`` decays at least as ``exp(-a t)``.
    extents : tuple of float
        Half-widths of the last two states (``e``, ``e'``; m and m/s per unit disturbance):
        ``sqrt((P^-1)_kk)``.
    max_eig, margin : float
        Largest eigenvalue of the verified LMI matrices and the round-off margin it cleared.
    integral_extent : float
        Half-width of the integrator state ``z`` (m s per unit disturbance; 0 without one).
    """

    matrix: FloatArray
    rate: float
    extents: tuple[float, float]
    max_eig: float
    margin: float
    integral_extent: float = 0.0


def _sym(m: Any) -> Any:
    return 0.5 * (m + m.T)


def _unit(n: int, k: int) -> FloatArray:
    e = np.zeros((n, 1))
    e[k, 0] = 1.0
    return e


def _schur(p: cp.Variable, t: cp.Variable, k: int) -> cp.Constraint:
    e = _unit(p.shape[0], k)
    return _sym(_CP.bmat([[p, e], [e.T, _CP.reshape(t, (1, 1), order="C")]])) >> 0


@lru_cache(maxsize=3)
def _position_sdp(
    n: int, capped: bool
) -> tuple[cp.Problem, dict[str, cp.Parameter], cp.Variable, tuple[cp.Variable, cp.Variable]]:
    """The position SDP on ``n`` states: ``(e, e')`` (n = 2) or ``(z, e, e')`` with integral action (n = 3).

    ``capped``: with a parameter ``cap`` bounding ``P_11`` (the integrator's start, see
    :func:`position_ellipsoid`).
    """
    a0, s1, s2 = cp.Parameter((n, n)), cp.Parameter((n, n), PSD=True), cp.Parameter((n, n), PSD=True)
    rate, weight = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    p = cp.Variable((n, n), symmetric=True)
    t1, t2 = cp.Variable(nonneg=True), cp.Variable(nonneg=True)
    te, tv = cp.Variable(), cp.Variable()
    pb = p @ _unit(n, n - 1)
    z = np.zeros((1, 1))
    top = a0.T @ p + p @ a0 + rate * p + t1 * s1 + t2 * s2
    m = _CP.bmat(
        [
            [top, pb, pb, pb],
            [pb.T, -_CP.reshape(t1, (1, 1), order="C"), z, z],
            [pb.T, z, -_CP.reshape(t2, (1, 1), order="C"), z],
            [pb.T, z, z, -_CP.reshape(rate, (1, 1), order="C")],
        ]
    )
    cons = [
        _sym(m) << -LYAP_STRICT_RTOL * _CP.trace(p) * np.eye(n + 3),
        p >> 0,
        _schur(p, te, n - 2),
        _schur(p, tv, n - 1),
    ]
    par: dict[str, cp.Parameter] = {"a0": a0, "s1": s1, "s2": s2, "rate": rate, "weight": weight}
    if capped:
        # the start: the integrator begins at z = 0, i.e. z~ = -z* off the equilibrium, which must
        # lie in {V <= d^2}: P_zz |z*|^2 <= d^2 (the caller gives cap = (d_min / |z*|_max)^2)
        par["cap"] = cp.Parameter(nonneg=True)
        cons.append(p[0, 0] <= par["cap"])
    prob = cp.Problem(cp.Minimize(te + weight * tv), cons)
    return prob, par, p, (t1, t2)


def position_matrix(
    p: FloatArray, taus: tuple[float, float], a0: FloatArray, s1: FloatArray, s2: FloatArray, rate: float
) -> FloatArray:
    """The ``(n + 3) x (n + 3)`` position LMI matrix (numpy), for the re-verification.

    Parameters
    ----------
    p : ndarray, shape (n, n)
        Candidate ``P``.
    taus : tuple of float
        S-procedure multipliers ``(tau1, tau2)``.
    a0 : ndarray, shape (n, n)
        Nominal loop matrix ``A0``.
    s1, s2 : ndarray, shape (n, n)
        Quadratic forms of the two uncertainty constraints: ``sigma^2 e_n e_n^T`` and
        ``delta^2 c^T c`` (see :func:`position_ellipsoid`).
    rate : float
        Rate ``a`` (1/s).
    """
    n = p.shape[0]
    pb = p @ _unit(n, n - 1)
    m = np.zeros((n + 3, n + 3))
    m[:n, :n] = a0.T @ p + p @ a0 + rate * p + taus[0] * s1 + taus[1] * s2
    for k in (n, n + 1, n + 2):
        m[:n, k : k + 1] = pb
        m[k : k + 1, :n] = pb.T
    m[n, n], m[n + 1, n + 1], m[n + 2, n + 2] = -taus[0], -taus[1], -rate
    return m


def _ellipsoid(p: FloatArray, rate: float, mats: list[FloatArray]) -> Ellipsoid | None:
    top, margin = -math.inf, 0.0
    for mat in mats:
        t, m = strict_nsd_gap(mat)
        if t >= -m:
            return None
        if t > top:
            top, margin = t, m
    t, m = strict_nsd_gap(-p)
    if t >= -m:
        return None
    half = np.sqrt(np.maximum(np.diag(np.linalg.inv(p)), 0.0))
    n = p.shape[0]
    ext = (float(half[n - 2]), float(half[n - 1]))
    return Ellipsoid(p, rate, ext, top, margin, float(half[0]) if n == 3 else 0.0)


def position_ellipsoid(
    a0: FloatArray,
    sigma: float,
    delta: float,
    c2: FloatArray,
    rate: float,
    weight: float,
    start_cap: float | None = None,
) -> Ellipsoid | None:
    """Invariant ellipsoid of the position loop at rate ``rate``; ``None`` if none is verified.

    Remembered per arguments (:data:`POSITION_CACHE`); the returned matrix is read-only.

    Without integral action ``a0 = [[0, 1], [-l k1, lam - l alpha]]`` and ``c2 = [k1, alpha]``;
    with it the state is ``(z, e, e')``, ``a0 = [[0, 1, 0], [0, 0, 1], [-l ki, -l k1, lam - l alpha]]``,
    ``c2 = [ki, k1, alpha]`` and ``start_cap`` bounds ``P_zz`` (the start of the integrator,
    see :func:`_position_sdp`).

    Parameters
    ----------
    a0 : ndarray, shape (n, n)
        Nominal loop matrix (n = 2, or 3 with integral action).
    sigma : float
        Bound of ``||D||`` acting on ``e'`` (1/s).
    delta : float
        Spread of the input gain ``L`` about its centre ``l`` (dimensionless).
    c2 : ndarray, shape (n,)
        Feedback gains ``[k1, alpha]`` (1/s^2, 1/s), or ``[ki, k1, alpha]`` with integral action.
    rate : float
        Rate ``a`` (1/s).
    weight : float
        Weight of the squared velocity half-width against the squared position half-width in
        the objective.
    start_cap : float, optional
        Upper bound of ``P_zz`` (with integral action only).
    """
    a = np.asarray(a0, dtype=float)
    c = np.asarray(c2, dtype=float)
    return _position_ellipsoid(
        a.tobytes(), a.shape[0], float(sigma), float(delta), c.tobytes(), float(rate), float(weight), start_cap
    )


#: Position ellipsoids remembered by :func:`position_ellipsoid` (``certify --preset bluerov2-line``
#: asks 1,580 times for 1,007 distinct ones).
POSITION_CACHE = 4096


@lru_cache(maxsize=POSITION_CACHE)
def _position_ellipsoid(
    a0_bytes: bytes,
    n: int,
    sigma: float,
    delta: float,
    c2_bytes: bytes,
    rate: float,
    weight: float,
    start_cap: float | None,
) -> Ellipsoid | None:
    a0 = np.frombuffer(a0_bytes, dtype=float).reshape(n, n)
    c2 = np.frombuffer(c2_bytes, dtype=float)
    prob, par, p, (t1, t2) = _position_sdp(n, start_cap is not None)
    s1 = sigma**2 * _unit(n, n - 1) @ _unit(n, n - 1).T
    c = np.asarray(c2, dtype=float).reshape(1, n)
    s2 = delta**2 * (c.T @ c)
    try:
        par["a0"].value, par["s1"].value, par["s2"].value = a0, s1, 0.5 * (s2 + s2.T)
        par["rate"].value, par["weight"].value = rate, weight
        if start_cap is not None:
            par["cap"].value = start_cap
        solve(prob, "robust position-loop ellipsoid LMI")
    except (SolverError, ValueError):
        # a failed solve, or data cvxpy refuses (a rank-one weight whose round-off fails its PSD
        # check when the gains are huge, e.g. a vehicle with a vanishing inertia): not certified
        return None
    pv = np.asarray(p.value, dtype=float)
    pv = 0.5 * (pv + pv.T)
    if start_cap is not None and pv[0, 0] > start_cap:
        return None  # the solver's tolerance let the start slip out: not certified
    taus = (float(t1.value), float(t2.value))
    ell = _ellipsoid(pv, rate, [position_matrix(pv, taus, a0, s1, s2, rate)])
    if ell is not None:
        ell.matrix.setflags(write=False)  # shared by every caller of the cache
    return ell


def clear_ellipsoid_caches() -> None:
    """Forget every remembered heading and position ellipsoid (benchmarks time cold designs with it)."""
    heading_ellipsoid.cache_clear()
    _position_ellipsoid.cache_clear()


@lru_cache(maxsize=1)
def _heading_sdp() -> tuple[cp.Problem, dict[str, Any], cp.Variable]:
    verts = [cp.Parameter((2, 2)) for _ in range(4)]
    rate, weight = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    q = cp.Variable((2, 2), symmetric=True)
    te, tv = cp.Variable(), cp.Variable()
    qb = q @ _B
    cons = [
        _sym(_CP.bmat([[a.T @ q + q @ a + rate * q, qb], [qb.T, -_CP.reshape(rate, (1, 1), order="C")]]))
        << -LYAP_STRICT_RTOL * _CP.trace(q) * np.eye(3)
        for a in verts
    ]
    cons += [q >> 0, _schur(q, te, 0), _schur(q, tv, 1)]
    prob = cp.Problem(cp.Minimize(te + weight * tv), cons)
    return prob, {"verts": verts, "rate": rate, "weight": weight}, q


def heading_matrix(q: FloatArray, a: FloatArray, rate: float) -> FloatArray:
    """The 3x3 heading LMI matrix at one vertex (numpy), for the re-verification.

    Parameters
    ----------
    q : ndarray, shape (2, 2)
        Candidate ``Q``.
    a : ndarray, shape (2, 2)
        Vertex matrix ``[[0, 1], [-K, -C]]``.
    rate : float
        Rate ``a`` (1/s).
    """
    m = np.zeros((3, 3))
    m[:2, :2] = a.T @ q + q @ a + rate * q
    m[:2, 2:] = q @ _B
    m[2:, :2] = (q @ _B).T
    m[2, 2] = -rate
    return m


def heading_vertices(stiffness: tuple[float, float], damping: tuple[float, float]) -> list[FloatArray]:
    """``A = [[0, 1], [-K, -C]]`` at the four corners of the ``(K, C)`` box.

    Parameters
    ----------
    stiffness : tuple of float
        ``[min, max]`` of ``K`` (1/s^2).
    damping : tuple of float
        ``[min, max]`` of ``C`` (1/s).
    """
    return [np.array([[0.0, 1.0], [-k, -c]]) for k in stiffness for c in damping]


#: Heading ellipsoids remembered by :func:`heading_ellipsoid`: a robust design meets the same
#: ``(K, C)`` boxes at the same rates many times (``certify --preset bluerov2-line`` asks 5,400
#: times for 899 distinct ones), and each answer is a verified SDP.
HEADING_CACHE = 4096


@lru_cache(maxsize=HEADING_CACHE)
def heading_ellipsoid(
    stiffness: tuple[float, float], damping: tuple[float, float], rate: float, weight: float
) -> Ellipsoid | None:
    """Invariant ellipsoid of the heading loop for every ``K(t), C(t)`` in the box; ``None`` if none.

    Remembered per arguments (:data:`HEADING_CACHE`); the returned matrix is read-only.

    Parameters
    ----------
    stiffness : tuple of float
        ``[min, max]`` of ``K`` (1/s^2).
    damping : tuple of float
        ``[min, max]`` of ``C`` (1/s).
    rate : float
        Rate ``a`` (1/s).
    weight : float
        Weight of the squared yaw-rate half-width against the squared heading half-width in
        the objective.
    """
    prob, par, q = _heading_sdp()
    verts = heading_vertices(stiffness, damping)
    for p_, a in zip(par["verts"], verts):
        p_.value = a
    par["rate"].value, par["weight"].value = rate, weight
    try:
        solve(prob, "robust heading-loop ellipsoid LMI")
    except SolverError:
        return None
    qv = np.asarray(q.value, dtype=float)
    qv = 0.5 * (qv + qv.T)
    ell = _ellipsoid(qv, rate, [heading_matrix(qv, a, rate) for a in verts])
    if ell is not None:
        ell.matrix.setflags(write=False)  # shared by every caller of the cache
    return ell


def best_ellipsoid(build: Callable[[float], Ellipsoid | None], rate_max: float, weight: float) -> Ellipsoid | None:
    """The verified ellipsoid of smallest ``ext_1^2 + weight ext_2^2`` over the rate.

    Coarse search over :data:`RATE_GRID` times ``rate_max``, then golden-section refinement
    (in ``log a``) between the neighbours of the best rate. Any verified ellipsoid is sound;
    the search only makes it small.

    Parameters
    ----------
    build : callable
        ``build(rate)``: the verified ellipsoid at rate ``rate`` (1/s), or None.
    rate_max : float
        Largest rate searched (1/s).
    weight : float
        The ``weight`` of the score ``ext_1^2 + weight ext_2^2``.
    """

    def score(e: Ellipsoid | None) -> float:
        return math.inf if e is None else e.extents[0] ** 2 + weight * e.extents[1] ** 2

    rates = [f * rate_max for f in RATE_GRID]
    found = [build(a) for a in rates]
    k = int(np.argmin([score(e) for e in found]))
    best = found[k]
    if best is None:
        return None
    lo = math.log(rates[max(k - 1, 0)])
    hi = math.log(rates[min(k + 1, len(rates) - 1)])
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(RATE_REFINEMENTS):
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        e1, e2 = build(math.exp(x1)), build(math.exp(x2))
        for e in (e1, e2):
            if score(e) < score(best):
                best = e
        if score(e1) <= score(e2):
            hi = x2
        else:
            lo = x1
    return best


#: Weight of the squared velocity half-width against ``l k1`` times the squared position
#: half-width in the position ellipsoid's objective: the velocity error decides the envelope
#: margins, so it is favoured (100 costs about 20 % in position and saves about 25 % in velocity).
VELOCITY_WEIGHT = 100.0


#: Relative change of the assumed heading bound at which the fixed-point iteration stops.
FIXED_POINT_RTOL = 1e-4


#: Iterations of the fixed point before giving up (it converges geometrically when it converges).
FIXED_POINT_ITERATIONS = 40


#: Relative inflations of the converged assumptions tried for the strict self-consistency check.
ASSUMPTION_INFLATIONS = (1e-2, 5e-2, 2e-1)


METHOD = (
    "per-vehicle perturbed error loops: multi-affine vertex sigma over the box, S-procedure invariant "
    "ellipsoid (position: ||D||<=sigma, ||L-l I||<=delta) and vertex LMI (heading: K, C boxes), "
    "fixed point of the coupling assumptions, interval envelope margins (first exit)"
)


@dataclass(frozen=True)
class RobustCertificate:
    """Verdict and numbers of the robust certificate for one box, current bound and gains.

    Attributes
    ----------
    gains : Gains
    box : ParameterBox
    current : float
        Bound of the current speed (m/s).
    stable : bool
        Both ellipsoids exist and the coupling assumptions are self-consistent.
    covers : bool
        ``stable``, the envelope holds with the error bounds, and the thrust is within the limit.
    bounds : ErrorBounds or None
        Per-vehicle error bounds over the certified set (m, m/s, rad, rad/s).
    assumptions : ErrorBounds or None
        The heading and velocity bounds assumed (strictly larger than the bounds).
    decay_rate : float or None
        ``min(a_position, a_heading)/2`` (1/s).
    lam, sigma : float
        Centre of ``G`` over the box and ``sup ||G - lam I||`` (1/s).
    gain_centre, gain_spread : float
        Centre and radius of the input gains ``m_jj_hat/m_jj``.
    position_disturbance : float or None
        Bound of ``|d|`` (m/s^2) under the assumptions.
    heading : HeadingPerturbation or None
    position_ellipsoid, heading_ellipsoid : Ellipsoid or None
        Per unit disturbance (scale by the disturbance bound).
    margins : Margins or None
    thrust : ThrustBounds or None
    reasons : tuple of str
        Why it does not cover (empty when it does).
    method : str
        The method, in words (:data:`METHOD`).
    integral_bound : float or None
        With integral action, bound of the integrator state ``|z|`` (m s); else None.
    operating : Envelope or None
        The operating envelope the bounds were computed over (:func:`robust_certificate`), or
        None when it is the declared one.
    wider : RobustCertificate or None
        With an operating envelope, the certificate over the declared one: its start set is
        larger and its bounds are looser, and a start in it alone is covered by it
        (:meth:`covering`).
    """

    gains: Gains
    box: ParameterBox
    current: float
    stable: bool
    covers: bool
    bounds: ErrorBounds | None
    assumptions: ErrorBounds | None
    decay_rate: float | None
    lam: float
    sigma: float
    gain_centre: float
    gain_spread: float
    position_disturbance: float | None = None
    heading: HeadingPerturbation | None = None
    position_ellipsoid: Ellipsoid | None = None
    heading_ellipsoid: Ellipsoid | None = None
    margins: Margins | None = None
    thrust: ThrustBounds | None = None
    reasons: tuple[str, ...] = field(default=())
    method: str = METHOD
    integral_bound: float | None = None
    operating: Envelope | None = None
    wider: RobustCertificate | None = None

    def equilibrium_shift(self, current: ArrayLike) -> FloatArray:
        """The current-shifted equilibrium the position ellipsoid is about, shape of ``current``.

        Without integral action ``e_c = -lam c/(l k1)`` (m) in the position error; with it the
        integrator absorbs the constant part, ``z* = -lam c/(l ki)`` (m s), and the position
        error's equilibrium is zero.

        Parameters
        ----------
        current : array_like, shape (..., 2)
            The current (m/s, inertial frame).
        """
        gain = self.gains.ki if self.gains.integral else self.gains.k1
        out: FloatArray = -self.lam * np.asarray(current, dtype=float) / (self.gain_centre * gain)
        return out

    def start_inside(
        self, e: FloatArray, de: FloatArray, epsi: FloatArray, depsi: FloatArray, current: ArrayLike
    ) -> bool:
        """Every vehicle's start errors lie in both certified sets (False when there are none).

        The sets are ``V(e - e_c, e') <= d^2`` (position ellipsoid on each axis pair) and
        ``W(e_psi, e_psi') <= h^2``.

        Parameters
        ----------
        e : ndarray, shape (N, 2)
            Position errors (m, inertial frame).
        de : ndarray, shape (N, 2)
            Ground-velocity errors (m/s, inertial frame).
        epsi : ndarray, shape (N,)
            Heading errors (rad).
        depsi : ndarray, shape (N,)
            Yaw-rate errors (rad/s).
        current : array_like, shape (2,)
            The current (m/s, inertial frame).
        """
        levels = self.start_levels(e, de, epsi, depsi, current)
        if levels is None:
            return False
        vp, vh, (top_p, top_h) = levels
        return bool(np.all(vp <= top_p) and np.all(vh <= top_h))

    def start_levels(
        self, e: FloatArray, de: FloatArray, epsi: FloatArray, depsi: FloatArray, current: ArrayLike
    ) -> tuple[FloatArray, FloatArray, tuple[float, float]] | None:
        """Every vehicle's levels in the two certified sets, and the sets' levels (``None``: no sets).

        The start lies in the sets when each level is at most its set's: ``V(e - e_c, e') <= d^2``
        (position, m and m/s) and ``W(e_psi, e_psi') <= h^2`` (heading, rad and rad/s).

        Parameters
        ----------
        e, de : ndarray, shape (N, 2)
            Position (m) and ground-velocity (m/s) errors, inertial frame.
        epsi, depsi : ndarray, shape (N,)
            Heading (rad) and yaw-rate (rad/s) errors.
        current : array_like, shape (2,)
            The current (m/s, inertial frame).
        """
        pos, head, hp, d = self.position_ellipsoid, self.heading_ellipsoid, self.heading, self.position_disturbance
        if pos is None or head is None or hp is None or d is None:
            return None
        shift = self.equilibrium_shift(current)
        if self.gains.integral:  # (z~, e, e') with the integrator starting at z = 0
            x = np.stack(np.broadcast_arrays(-shift, np.asarray(e, dtype=float), np.asarray(de, dtype=float)), -1)
            vp = np.einsum("...ak,kl,...al->...", x, pos.matrix, x)
        else:
            vp = pair_level(pos.matrix, e - shift, de, planar=True)
        vh = pair_level(head.matrix, epsi, depsi)
        return vp, vh, (d**2, hp.disturbance**2)

    def covering(
        self, e: FloatArray, de: FloatArray, epsi: FloatArray, depsi: FloatArray, current: ArrayLike
    ) -> RobustCertificate | None:
        """The tightest covering certificate whose start set holds every vehicle's start, or None.

        This certificate when the start lies in its sets, else the declared envelope's
        (:attr:`wider`) when it covers and the start lies in its larger sets. The arguments are
        those of :meth:`start_inside`.

        Parameters
        ----------
        e, de : ndarray, shape (N, 2)
            Position (m) and ground-velocity (m/s) errors, inertial frame.
        epsi, depsi : ndarray, shape (N,)
            Heading (rad) and yaw-rate (rad/s) errors.
        current : array_like, shape (2,)
            The current (m/s, inertial frame).
        """
        if self.covers and self.start_inside(e, de, epsi, depsi, current):
            return self
        w = self.wider
        return w if w is not None and w.covers and w.start_inside(e, de, epsi, depsi, current) else None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary."""
        b = self.bounds
        return {
            "stable": self.stable,
            "covers": self.covers,
            "decay_rate": self.decay_rate,
            "ultimate_bounds": None
            if b is None
            else {"position": b.position, "velocity": b.velocity, "heading": b.heading, "yaw_rate": b.yaw_rate},
            "gains": self.gains.to_dict(),
            "lambda": self.lam,
            "sigma": self.sigma,
            "input_gain": [self.gain_centre - self.gain_spread, self.gain_centre + self.gain_spread],
            "position_disturbance": self.position_disturbance,
            "heading_stiffness": None if self.heading is None else list(self.heading.stiffness),
            "heading_damping": None if self.heading is None else list(self.heading.damping),
            "heading_disturbance": None if self.heading is None else self.heading.disturbance,
            "envelope_margins": None if self.margins is None else self.margins.to_dict(),
            "thrust": None if self.thrust is None else self.thrust.to_dict(),
            "current_speed": self.current,
            "reasons": list(self.reasons),
            "method": self.method,
            "operating_envelope": None
            if self.operating is None
            else {"u": list(self.operating.u), "v": list(self.operating.v), "r": list(self.operating.r)},
            "declared_sigma": None if self.wider is None else self.wider.sigma,
        } | ({} if self.integral_bound is None else {"integral_bound": self.integral_bound})


def _stable_rate(a0: np.ndarray) -> float:
    """Twice the stability margin ``-max Re eig(a0)`` (1/s), the largest rate worth trying."""
    return float(-2.0 * np.linalg.eigvals(a0).real.max())


def _heading_rate(hp: HeadingPerturbation) -> float:
    k, c = hp.stiffness[0], hp.damping[0]
    roots = np.roots([1.0, c, k])
    return float(-2.0 * roots.real.max())


def _position_loop(
    box: ParameterBox, env: Envelope, summ: TubeSummary, gains: Gains, current: float, lam: float, sigma: float
) -> tuple[FloatArray, FloatArray, float, float | None]:
    """Centre matrix, delta-channel row, ``|z*|`` bound (m s) and ``P_zz`` cap of the position loop.

    With integral action the state is ``(z~, e, e')``, ``z~ = z - z*``, and the integrator starts
    at ``z = 0``: the start ``z~ = -z*`` must lie in ``{V <= d^2}`` for every admissible current.
    The disturbance bound ``d`` only grows with the assumed heading error, so its value at zero
    heading error is a lower bound, and ``P_zz <= (d_0/|z*|_max)^2`` keeps every such start inside.
    """
    lc, _ = box.input_gain()
    if not gains.integral:
        return (
            np.array([[0.0, 1.0], [-lc * gains.k1, lam - lc * gains.alpha]]),
            np.array([gains.k1, gains.alpha]),
            0.0,
            None,
        )
    a0 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-lc * gains.ki, -lc * gains.k1, lam - lc * gains.alpha]])
    c2 = np.array([gains.ki, gains.k1, gains.alpha])
    z_star = abs(lam) * current / (lc * gains.ki)
    if z_star == 0.0:
        return a0, c2, 0.0, None
    d0 = position_disturbance(box, env, summ, current, 0.0, lam, sigma)
    return a0, c2, z_star, (d0 / z_star) ** 2


def _heading_at(
    box: ParameterBox,
    env: Envelope,
    tube: TubeSummary,
    gains: Gains,
    current: float,
    velocity: float,
    heading: float,
) -> tuple[HeadingPerturbation, Ellipsoid | None]:
    hp = heading_perturbation(box, env, tube, gains.k_psi, current, velocity, heading)
    if hp.stiffness[0] <= 0.0 or hp.damping[0] <= 0.0:
        return hp, None
    weight = 1.0 / max(hp.stiffness[0], 1e-12)
    ell = best_ellipsoid(lambda a: heading_ellipsoid(hp.stiffness, hp.damping, a, weight), _heading_rate(hp), weight)
    return hp, ell


#: Relative widening of the operating envelope (:func:`~auv_hinf.mission.margins.operating_envelope`)
#: around the velocities the declared envelope's certificate allows: the room the second certificate's
#: bounds need to lie strictly inside it (its ellipsoid search is numerical, so its bounds need not
#: fall monotonically); 5 % of a BlueROV2's 0.65 m/s is 0.03 m/s, which moves sigma by about 3 %.
#: The refinement is computed once: on the BlueROV2 line it takes the surge force from 102 to 81 N,
#: and a second, at about the same cost again, would take about 2 N more.
OPERATING_WIDEN = 0.05


def robust_certificate(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    current: float = 0.0,
    actuators: Actuators | None = None,
    *,
    until_covered: bool = False,
) -> RobustCertificate:
    """Certify the closed loop of ``gains`` for every plant of ``box`` and current ``<= current``.

    The certificate is first computed over the declared envelope: its drag slopes, model
    mismatch and Munk moments are bounded at the envelope's widest velocities. When it holds,
    it is computed once more over the *operating* envelope, the velocities its own bounds allow
    (the mission's plus the errors' and the current's, widened by :data:`OPERATING_WIDEN`,
    :func:`~auv_hinf.mission.margins.operating_envelope`), and kept when its bounds lie inside
    that envelope, its velocity bound is no larger and it covers if the first did: a trajectory
    starting in the certified set cannot be the first to leave the operating envelope, since up
    to that time the second certificate bounds its errors, and so its velocities, strictly inside
    it (first exit). The tighter bounds come with smaller start sets: the declared envelope's
    certificate stays attached (``wider``) and covers the starts only it holds
    (:meth:`RobustCertificate.covering`).

    Parameters
    ----------
    box : ParameterBox
        Declared plant box around the controller's model.
    envelope : Envelope
        Operating envelope (body velocities, m/s and rad/s).
    tube : ReferenceTube
        Sound bounds of the desired motion (e.g. :func:`~auv_hinf.mission.tubes.mission_tube`).
    gains : Gains
    current : float
        Bound of the constant current's speed (m/s, >= 0).
    actuators : Actuators, optional
        What the vehicles can push: the certificate covers only if its thrust bound fits.
    until_covered : bool
        Refine only when the declared envelope's certificate does not cover (a search that reads
        :attr:`RobustCertificate.covers` alone): the verdict is the same, the bounds may be looser.
    """
    declared = _certificate_on(box, envelope, tube, gains, current, actuators)
    b = declared.bounds
    if b is None or declared.margins is None or not declared.margins.ok or (until_covered and declared.covers):
        return declared
    op = operating_envelope(tube, _through_water(b, current), envelope, OPERATING_WIDEN)
    cert = _certificate_on(box, op, tube, gains, current, actuators)
    nb = cert.bounds
    if nb is None or cert.margins is None or not cert.margins.ok or nb.velocity > b.velocity:
        return declared  # not inside its own operating envelope, or no tighter
    if declared.covers and not cert.covers:
        return declared  # tighter but refused (a force the numerical search put higher)
    # the margins reported are the declared envelope's (the operating one's hold by construction)
    margins = envelope_margins(tube, _through_water(nb, current), envelope)
    return replace(cert, operating=op, wider=declared, margins=margins)


def _through_water(bounds: ErrorBounds, current: float) -> ErrorBounds:
    """``bounds`` with the current's speed (m/s) added to the velocity bound: body velocities are through the water."""
    return ErrorBounds(bounds.position, bounds.velocity + current, bounds.heading, bounds.yaw_rate)


def _certificate_on(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    current: float,
    actuators: Actuators | None,
) -> RobustCertificate:
    """The certificate with every velocity-dependent bound taken over ``envelope`` (see :func:`robust_certificate`)."""
    env = inflate_envelope(envelope)
    lam, sigma = box_lambda(box, env)
    lc, spread = box.input_gain()
    base: dict[str, Any] = {"gains": gains, "box": box, "current": current, "lam": lam, "sigma": sigma}
    base |= {"gain_centre": lc, "gain_spread": spread}

    def fail(reason: str, **kw: Any) -> RobustCertificate:
        return RobustCertificate(
            stable=False, covers=False, bounds=None, assumptions=None, decay_rate=None, reasons=(reason,), **base, **kw
        )

    summ = TubeSummary.of(tube)
    a0, c2, z_star, cap = _position_loop(box, env, summ, gains, current, lam, sigma)
    if not np.all(np.linalg.eigvals(a0).real < 0):
        return fail("the centre of the perturbed position loop is not stable (alpha, k1 or ki)")
    wp = VELOCITY_WEIGHT / (lc * gains.k1)
    pos = best_ellipsoid(lambda a: position_ellipsoid(a0, sigma, spread, c2, a, wp, cap), _stable_rate(a0), wp)
    if pos is None:
        start = " that holds the integrator's start" if cap is not None else ""
        return fail(
            f"no invariant ellipsoid of the position loop{start} (sigma = {sigma:.4g} 1/s, "
            f"input-gain spread {spread:.3g})"
        )
    e_h = 0.0
    for _ in range(FIXED_POINT_ITERATIONS):
        e_v = position_disturbance(box, env, summ, current, e_h, lam, sigma) * pos.extents[1]
        hp, head = _heading_at(box, env, summ, gains, current, e_v, e_h)
        if head is None:
            ranges = (
                f"stiffness in [{hp.stiffness[0]:.4g}, {hp.stiffness[1]:.4g}] 1/s^2, "
                f"damping in [{hp.damping[0]:.4g}, {hp.damping[1]:.4g}] 1/s"
            )
            if hp.stiffness[0] > 0.0 and hp.damping[0] > 0.0:
                # every frozen loop of the ranges is stable; the loop whose stiffness and damping move
                # within them (they follow the sway velocity and the heading) is not proven so
                why = (
                    f"heading loop not proven stable: its {ranges} move with the sway velocity and the heading, and "
                    "no invariant ellipsoid holds for every such motion (each fixed loop in the ranges is stable, "
                    "a loop whose coefficients vary in time need not be)"
                )
            else:
                why = f"heading loop not robustly stable: {ranges} (a nonpositive end is an unstable loop)"
            return fail(why, position_ellipsoid=pos, heading=hp)
        new = hp.disturbance * head.extents[0]
        if not new < MAX_HEADING_ERROR:
            return fail(f"the heading-error bound diverges ({new:.3g} rad)", position_ellipsoid=pos, heading=hp)
        done = abs(new - e_h) <= FIXED_POINT_RTOL * max(new, 1e-300)
        e_h = new
        if done:
            break
    for eta in ASSUMPTION_INFLATIONS:
        a_h = e_h * (1.0 + eta)
        dbar = position_disturbance(box, env, summ, current, a_h, lam, sigma)
        a_v = dbar * pos.extents[1] * (1.0 + eta)
        hp, head = _heading_at(box, env, summ, gains, current, a_v, a_h)
        if head is None:
            continue
        b_h, b_r = hp.disturbance * head.extents[0], hp.disturbance * head.extents[1]
        offset = 0.0 if gains.integral else current_offset(box, lam, current, gains.k1)
        b_p, b_v = dbar * pos.extents[0] + offset, dbar * pos.extents[1]
        if b_h <= a_h and b_v <= a_v and a_h < MAX_HEADING_ERROR:
            break
    else:
        return fail("the coupling assumptions are not self-consistent (the fixed point does not verify)")
    bounds = ErrorBounds(b_p, b_v, b_h, b_r)
    rest: dict[str, Any] = {
        "bounds": bounds,
        "assumptions": ErrorBounds(b_p, a_v, a_h, b_r),
        "decay_rate": 0.5 * min(pos.rate, head.rate),
        "position_disturbance": dbar,
        "heading": hp,
        "position_ellipsoid": pos,
        "heading_ellipsoid": head,
    }
    reasons: list[str] = []
    try:
        margins: Margins | None = envelope_margins(tube, _through_water(bounds, current), envelope)
    except AuvHinfError as exc:
        margins = None
        reasons.append(f"envelope margins: {exc}")
    if margins is not None and not margins.ok:
        reasons.append(f"the envelope does not hold with these error bounds (smallest margin {margins.min:.4g})")
    b_z = dbar * pos.integral_extent + z_star if gains.integral else None  # |z| <= |z~| + |z*| (m s)
    # the feedback on the ellipsoid about the shifted equilibrium, plus the equilibrium's own:
    # l times it cancels -lam c, so |k1 e_c| = |ki z*| = |lam| c / l with or without integral action
    feedback = ellipsoid_feedback(pos.matrix, c2, dbar**2) + abs(lam) * current / lc
    thrust = thrust_bounds(box.nominal, env, tube, bounds, gains, current, b_z or 0.0, feedback)
    if actuators is not None and not actuators.admits(thrust.as_tuple()):
        reasons.append(actuator_shortfall(actuators, thrust.as_tuple()))
    return RobustCertificate(
        stable=True,
        covers=not reasons,
        margins=margins,
        thrust=thrust,
        reasons=tuple(reasons),
        integral_bound=b_z,
        **base,
        **rest,
    )


__all__ = [
    "ASSUMPTION_INFLATIONS",
    "FIXED_POINT_ITERATIONS",
    "FIXED_POINT_RTOL",
    "METHOD",
    "OPERATING_WIDEN",
    "RATE_GRID",
    "RATE_REFINEMENTS",
    "VELOCITY_WEIGHT",
    "Ellipsoid",
    "RobustCertificate",
    "best_ellipsoid",
    "clear_ellipsoid_caches",
    "heading_ellipsoid",
    "heading_matrix",
    "heading_vertices",
    "position_ellipsoid",
    "position_matrix",
    "robust_certificate",
]
