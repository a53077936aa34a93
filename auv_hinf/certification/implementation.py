"""The certificate of the controller as it runs: sampled, held, delayed, noisy.

Per vehicle and per loop (position, heading) the lagged law is certified by a
Lyapunov-Krasovskii functional (:mod:`auv_hinf.design.lmi.sampled`) for every measurement age
up to ``T = sample_time + delay``; the implementation's remaining effects are a bounded
disturbance (:mod:`auv_hinf.certification.lag_terms`) whose size depends on the error bounds
through the force the law commands. The error bounds are the least fixed point of

    bounds -> force(bounds + noise) -> disturbance -> invariant level -> bounds,

iterated from the start's level and accepted only when one more step, from bounds widened by
:data:`FIXED_POINT_RTOL`, lands inside them (then, by the first-exit argument of
:mod:`auv_hinf.certification.region`, the errors never leave them). The envelope margins of
those bounds, the LMI and (when declared) the actuators decide ``covers``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.certification.closed_loop import ThrustBounds, thrust_bounds
from auv_hinf.certification.lag_terms import LagDisturbance, block_slopes, lag_disturbance
from auv_hinf.certification.margins import MAX_HEADING_ERROR, ErrorBounds, envelope_margins, inflate_envelope
from auv_hinf.certification.sampling import certified_lag, decay_at, exact_limit, iss_certificate
from auv_hinf.design.gains import Gains
from auv_hinf.design.lmi.sampled import LagLoop, LagResult
from auv_hinf.models.actuators import Actuators
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.implementation import Implementation
from auv_hinf.models.reference import ReferenceTube
from auv_hinf.models.vehicle import VehicleParams

#: Relative widening of the fixed-point bounds before the final self-consistency step.
FIXED_POINT_RTOL = 1e-6
#: Iterations of the fixed point before it is declared divergent.
FIXED_POINT_ITERATIONS = 200
#: Fraction of the largest certified decay rate used for the ISS certificate: halfway keeps
#: both the decay and the ISS gain finite (at the largest rate the gain blows up).
ISS_DECAY_FRACTION = 0.5

METHOD = (
    "input-delay approach: Lyapunov-Krasovskii functional with Jensen's bound for every measurement "
    "age in [0, sample_time + delay] (Fridman 2014), per-vehicle position (||D|| <= sigma, S-procedure) "
    "and heading (vertex damping) loops; held-command, reference and noise terms as a bounded "
    "disturbance (ISS); bounds by a verified fixed point; exact reference by python-control c2d"
)


def position_loop(gains: Gains, lam: float, sigma: float, lag_sigma: float = 0.0) -> LagLoop:
    """The position error loop: ``a = lam``, ``K = (k1, alpha)``, ``|q| <= sigma |e'|``, ``|q2| <= lag_sigma |delta_2|``."""
    return LagLoop((lam,), gains.k1, gains.alpha, sigma, lag_sigma)


def heading_loop(gains: Gains, c_range: tuple[float, float]) -> LagLoop:
    """The heading error loop: ``a = -(c - k2psi)`` at both ends of ``c``, ``K = k_psi``."""
    k1p, k2p = gains.k_psi
    return LagLoop((-(c_range[0] - k2p), -(c_range[1] - k2p)), k1p, k2p)


def _level(p: FloatArray, r1: float, r2: float) -> float:
    """Largest ``x^T P x`` over ``|x1| <= r1, |x2| <= r2`` (planar pairs, exact)."""
    return float(p[0, 0] * r1 * r1 + 2.0 * abs(p[0, 1]) * r1 * r2 + p[1, 1] * r2 * r2)


def _extents(p: FloatArray, level: float) -> tuple[float, float]:
    """Sup of ``|x1|``, ``|x2|`` over ``{x^T P x <= level}``."""
    inv = np.linalg.inv(p)
    return math.sqrt(max(level, 0.0) * inv[0, 0]), math.sqrt(max(level, 0.0) * inv[1, 1])


@dataclass(frozen=True)
class LagLimits:
    """Certified and exact limits of one configuration's loops (s).

    Attributes
    ----------
    lag : float
        Largest certified ``sample_time + delay``.
    exact_sample_time : float
        First unstable sample time of the nominal loops at the declared delay (``inf``: none).
    """

    lag: float
    exact_sample_time: float


def lag_limits(loops: tuple[LagLoop, LagLoop], nominal_dampings: tuple[float, float], delay: float) -> LagLimits:
    """:func:`certified_lag` of both loops and :func:`exact_limit` of their nominal members."""
    lag = min(certified_lag(loop) for loop in loops)
    exact = min(exact_limit(a, lp.k, lp.b, delay) for a, lp in zip(nominal_dampings, loops, strict=True))
    return LagLimits(lag=lag, exact_sample_time=exact)


@dataclass(frozen=True)
class ImplementationCertificate:
    """What is certified about the implemented controller (see the module docstring).

    Attributes
    ----------
    implementation : Implementation
    max_sample_time, max_delay : float
        Largest sample time (delay fixed) and delay (sample time fixed) still certified (s).
    exact_max_sample_time : float
        The nominal loops' exact limit at the declared delay (s; ``inf`` when none).
    decay_rate : float or None
        Rate (1/s) of the ISS certificate: errors approach the ultimate bounds like ``exp(-rate t)``.
    bounds : ErrorBounds or None
        Bounds of the errors over the whole run from the start (m, m/s, rad, rad/s).
    ultimate : ErrorBounds or None
        Bounds the errors enter and stay in as ``t -> inf``.
    thrust : ThrustBounds or None
        Bounds of the commanded forces, noise-driven commands included (N, N, N m).
    covers : bool
    reasons : tuple of str
        Why it does not cover (empty when it does).
    disturbance : LagDisturbance or None
    certificates : tuple of LagResult
        The verified position and heading certificates (empty when none).
    """

    implementation: Implementation
    max_sample_time: float
    max_delay: float
    exact_max_sample_time: float
    decay_rate: float | None
    bounds: ErrorBounds | None
    ultimate: ErrorBounds | None
    thrust: ThrustBounds | None
    covers: bool
    reasons: tuple[str, ...]
    disturbance: LagDisturbance | None = None
    certificates: tuple[LagResult, ...] = ()
    method: str = METHOD

    @property
    def tightness(self) -> float | None:
        """``max_sample_time / exact_max_sample_time`` (<= 1 by soundness); None when undefined."""
        ex = self.exact_max_sample_time
        return self.max_sample_time / ex if 0 < ex < math.inf else None

    def to_dict(self) -> dict[str, Any]:
        """The ``implementation`` object of ``auv-hinf certify --json``."""

        def eb(b: ErrorBounds | None) -> dict[str, float] | None:
            return None if b is None else b.to_dict()

        ex = self.exact_max_sample_time
        return {
            **self.implementation.to_dict(),
            "continuous": self.implementation.continuous,
            "max_sample_time": self.max_sample_time,
            "max_delay": self.max_delay,
            "exact_max_sample_time": ex if math.isfinite(ex) else None,
            "tightness": self.tightness,
            "decay_rate": self.decay_rate,
            "ultimate_bounds": eb(self.ultimate),
            "error_bounds": eb(self.bounds),
            "thrust": None if self.thrust is None else self.thrust.to_dict(),
            "disturbance": None
            if self.disturbance is None
            else {"position": self.disturbance.position, "heading": self.disturbance.heading},
            "covers": self.covers,
            "reasons": list(self.reasons),
            "method": self.method,
        }


@dataclass(frozen=True)
class ImplementationProblem:
    """Everything the implementation certificate of one configuration depends on.

    Attributes
    ----------
    params, envelope, tube, gains
        The controller's model (taken as the plant), envelope, reference tube and gains.
    lam, sigma : float
        Envelope lambda and ``||G - lam I||`` bound (1/s).
    c_range : tuple of float
        Range of the heading loop's damping ``k2psi + d33(r)/m33`` (1/s).
    jerk : float
        Bound of ``|p_d'''|`` (m/s^3).
    actuators : Actuators or None
    yaw_jerk : float
        Bound of ``|psi_d'''|`` (rad/s^3); ``inf`` when unknown.
    """

    params: VehicleParams
    envelope: Envelope
    tube: ReferenceTube
    gains: Gains
    lam: float
    sigma: float
    c_range: tuple[float, float]
    jerk: float
    actuators: Actuators | None = None
    yaw_jerk: float = math.inf

    @property
    def loops(self) -> tuple[LagLoop, LagLoop]:
        """Position and heading :class:`LagLoop` of the stability limits (no lag channel)."""
        return self.lag_loops(False)

    def lag_loops(self, channel: bool) -> tuple[LagLoop, LagLoop]:
        """Position and heading :class:`LagLoop`, with the position lag channel when ``channel``.

        The lag channel is the drift feedforward ``G(y) p_d'`` evaluated at the old state: its
        part driven by the velocity error's change is at most ``max |p_d'| hypot(b_u, b_v)
        |delta_2|`` (:func:`~auv_hinf.certification.lag_terms.block_slopes`).
        """
        b_u, b_v, _ = block_slopes(self.params)
        lag_sigma = float(self.tube.speed[:, 1].max()) * math.hypot(b_u, b_v) if channel else 0.0
        return position_loop(self.gains, self.lam, self.sigma, lag_sigma), heading_loop(self.gains, self.c_range)

    @property
    def nominal_dampings(self) -> tuple[float, float]:
        """``a`` of the nominal loops: ``lam`` (``D = 0``) and the smallest yaw damping."""
        return self.lam, -(self.c_range[0] - self.gains.k_psi[1])


def _force(prob: ImplementationProblem, bounds: ErrorBounds, impl: Implementation) -> ThrustBounds:
    """Bound of the commanded forces on measurements with errors up to ``bounds + noise``."""
    n = impl.noise
    env = prob.envelope
    wide = replace(
        env,
        u=(env.u[0] - n.velocity, env.u[1] + n.velocity),
        v=(env.v[0] - n.velocity, env.v[1] + n.velocity),
        r=(env.r[0] - n.yaw_rate, env.r[1] + n.yaw_rate),
    )
    seen = ErrorBounds(
        bounds.position + n.position,
        bounds.velocity + n.velocity + math.hypot(max(map(abs, env.u)), max(map(abs, env.v))) * n.heading,
        bounds.heading + n.heading,
        bounds.yaw_rate + n.yaw_rate,
    )
    return thrust_bounds(prob.params, inflate_envelope(wide), prob.tube, seen, prob.gains)


def _step(
    prob: ImplementationProblem,
    impl: Implementation,
    certs: tuple[LagResult, LagResult],
    start: tuple[float, float],
    bounds: ErrorBounds,
    channel: bool,
) -> tuple[ErrorBounds, ErrorBounds, LagDisturbance, ThrustBounds]:
    """One fixed-point step: bounds -> (new bounds, ultimate bounds, disturbance, force)."""
    force = _force(prob, bounds, impl)
    dist = lag_disturbance(
        prob.params, prob.envelope, prob.tube, prob.gains, impl, lam=prob.lam, sigma=prob.sigma,
        jerk=prob.jerk, force=force, bounds=bounds, yaw_jerk=prob.yaw_jerk, lag_channel=channel,
    )
    out, ult = [], []
    for cert, w, v0 in zip(certs, (dist.position, dist.heading), start, strict=True):
        floor = cert.gain * w * w / (2.0 * cert.beta)
        out += _extents(cert.p, max(v0, floor))
        ult += _extents(cert.p, floor)
    return ErrorBounds(*out), ErrorBounds(*ult), dist, force


def _fits(prob: ImplementationProblem, b: ErrorBounds) -> bool:
    return b.heading < MAX_HEADING_ERROR and envelope_margins(prob.tube, b, prob.envelope).ok


def certify_implementation(
    prob: ImplementationProblem, impl: Implementation, start: ErrorBounds, limits: LagLimits | None = None
) -> ImplementationCertificate:
    """The implementation certificate of ``prob`` run as ``impl`` from errors within ``start``.

    Parameters
    ----------
    prob : ImplementationProblem
    impl : Implementation
    start : ErrorBounds
        Bounds of every vehicle's errors at ``t = 0`` against the reference (m, m/s, rad, rad/s).
    limits : LagLimits, optional
        :func:`lag_limits` of ``prob`` at ``impl.delay``, when the caller has them.
    """
    loops = prob.loops
    limits = limits or lag_limits(loops, prob.nominal_dampings, impl.delay)
    max_h, max_d = max(limits.lag - impl.delay, 0.0), max(limits.lag - impl.sample_time, 0.0)
    base = {
        "implementation": impl,
        "max_sample_time": max_h,
        "max_delay": max_d,
        "exact_max_sample_time": limits.exact_sample_time,
    }
    lag = impl.max_lag
    if lag > limits.lag:
        why = (
            f"sample_time + delay = {lag:.4g} s exceeds the certified {limits.lag:.4g} s: at delay {impl.delay:.4g} s "
            f"the sample time must be <= {max_h:.4g} s (exact nominal limit {limits.exact_sample_time:.4g} s); "
            "lower the gains' bandwidth or sample faster"
        )
        return ImplementationCertificate(**base, decay_rate=None, bounds=None, ultimate=None, thrust=None,
                                         covers=False, reasons=(why,))
    attempts = [_bounded(prob, impl, start, channel) for channel in (True, False)]
    best = next((a for a in attempts if a.covers), attempts[-1])
    return ImplementationCertificate(**base, **best.fields())


@dataclass(frozen=True)
class _Attempt:
    """One way of bounding the implementation's effects (with or without the lag channel ``q2``)."""

    covers: bool
    reasons: tuple[str, ...]
    decay_rate: float | None = None
    bounds: ErrorBounds | None = None
    ultimate: ErrorBounds | None = None
    thrust: ThrustBounds | None = None
    disturbance: LagDisturbance | None = None
    certificates: tuple[LagResult, ...] = ()

    def fields(self) -> dict[str, Any]:
        return {
            "decay_rate": self.decay_rate,
            "bounds": self.bounds,
            "ultimate": self.ultimate,
            "thrust": self.thrust,
            "covers": self.covers,
            "reasons": self.reasons,
            "disturbance": self.disturbance,
            "certificates": self.certificates,
        }


def _bounded(prob: ImplementationProblem, impl: Implementation, start: ErrorBounds, channel: bool) -> _Attempt:
    """ISS certificates at the declared lag and the verified fixed point of the error bounds.

    ``channel``: the drift feedforward's dependence on the velocity error's change is a
    norm-bounded term of the position LMI (``q2``); otherwise it is part of the disturbance,
    bounded through the body accelerations.
    """
    lag = impl.max_lag
    loops = prob.lag_loops(channel)
    rates = [ISS_DECAY_FRACTION * decay_at(loop, lag) for loop in loops]
    certs = tuple(
        iss_certificate(loop, lag, beta, np.diag([loop.k, 1.0])) if beta > 0 else None
        for loop, beta in zip(loops, rates, strict=True)
    )
    if certs[0] is None or certs[1] is None:
        return _Attempt(False, (f"no decay rate is certified at sample_time + delay = {lag:.4g} s",))
    pair = (certs[0], certs[1])
    v0 = (_level(pair[0].p, start.position, start.velocity), _level(pair[1].p, start.heading, start.yaw_rate))
    bounds = ErrorBounds(*_extents(pair[0].p, v0[0]), *_extents(pair[1].p, v0[1]))
    reasons: list[str] = []
    for _ in range(FIXED_POINT_ITERATIONS):
        if not _fits(prob, bounds):
            reasons.append(
                "the error bounds leave the envelope: the implementation's disturbance is too large "
                f"(last bounds |e| <= {bounds.position:.3g} m, |e'| <= {bounds.velocity:.3g} m/s, "
                f"|e_psi| <= {bounds.heading:.3g} rad)"
            )
            break
        new, ult, dist, force = _step(prob, impl, pair, v0, bounds, channel)
        if all(n <= b * (1.0 + 1e-12) + 1e-300 for n, b in zip(_vec(new), _vec(bounds), strict=True)):
            break
        bounds = ErrorBounds(*np.maximum(_vec(new), _vec(bounds)))
    else:
        reasons.append(f"the error bounds did not settle in {FIXED_POINT_ITERATIONS} iterations")
    if reasons:
        return _Attempt(False, tuple(reasons), decay_rate=min(c.beta for c in pair), certificates=pair)
    wide = ErrorBounds(*(_vec(bounds) * (1.0 + FIXED_POINT_RTOL)))
    new, ult, dist, force = _step(prob, impl, pair, v0, wide, channel)
    if not (np.all(_vec(new) <= _vec(wide)) and _fits(prob, wide)):
        reasons.append("the error bounds are not self-consistent (fixed-point check failed)")
    if not reasons and prob.actuators is not None and not prob.actuators.admits(force.as_tuple()):
        reasons.append(
            f"the commanded forces (|tau_x| <= {force.force_x:.4g} N, |tau_y| <= {force.force_y:.4g} N, "
            f"|tau_psi| <= {force.moment:.4g} N m, noise included) exceed the actuators"
        )
    ok = not reasons
    return _Attempt(
        ok,
        tuple(reasons),
        decay_rate=min(c.beta for c in pair),
        bounds=wide if ok else None,
        ultimate=ult if ok else None,
        thrust=force,
        disturbance=dist,
        certificates=pair,
    )


def _vec(b: ErrorBounds) -> FloatArray:
    return np.array([b.position, b.velocity, b.heading, b.yaw_rate])


__all__ = [
    "FIXED_POINT_RTOL",
    "ISS_DECAY_FRACTION",
    "ImplementationCertificate",
    "ImplementationProblem",
    "LagLimits",
    "certify_implementation",
    "heading_loop",
    "lag_limits",
    "position_loop",
]
