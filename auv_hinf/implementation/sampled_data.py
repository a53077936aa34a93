"""The certificate of the controller as it runs: sampled, held, delayed, noisy.

Per vehicle and per loop (position, heading) the lagged law is certified by a
Lyapunov-Krasovskii functional (:mod:`auv_hinf.implementation.lmi`) for every measurement age
up to ``T = sample_time + delay``; the implementation's remaining effects are a bounded
disturbance (:mod:`auv_hinf.implementation.lag`) whose size depends on the error bounds
through the force the law commands. The envelope margins of the bounds, the LMI and (when
declared) the actuators decide ``covers``; :func:`lag_limits` gives the certified and the exact
sample-time limits (:mod:`auv_hinf.implementation.limits`).

The error bounds are a verified fixed point. For one way of bounding the lag's effects (the
drift feedforward as the LMI's lag channel ``q2``, or inside the disturbance),
:func:`bound_errors` computes the ISS certificates of both loops at the declared lag and the
least fixed point of

    bounds -> force(bounds + noise) -> disturbance -> invariant level -> bounds,

iterated from the start's level and accepted only when one more step, from bounds widened by
:data:`FIXED_POINT_RTOL`, lands inside them and inside the envelope: then, by the first-exit
argument of :mod:`auv_hinf.closed_loop.region`, the errors never leave them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrust import ThrustBounds, thrust_bounds
from auv_hinf.implementation.lag import ImplementationProblem, LagDisturbance, lag_disturbance
from auv_hinf.implementation.limits import certified_lag, decay_at, exact_limit, iss_certificate
from auv_hinf.implementation.lmi import LagLoop, LagResult
from auv_hinf.implementation.model import Implementation
from auv_hinf.mission.margins import MAX_HEADING_ERROR, ErrorBounds, envelope_margins, inflate_envelope
from auv_hinf.numerics.quadratic_forms import box_level, level_extent

#: Relative widening of the fixed-point bounds before the final self-consistency step.
FIXED_POINT_RTOL = 1e-6


#: Iterations of the fixed point before it is declared divergent.
FIXED_POINT_ITERATIONS = 200


#: Fraction of the largest certified decay rate used for the ISS certificate: halfway keeps
#: both the decay and the ISS gain finite (at the largest rate the gain blows up).
ISS_DECAY_FRACTION = 0.5


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
    state: FloatArray,
    channel: bool,
) -> tuple[FloatArray, ErrorBounds, LagDisturbance, ThrustBounds]:
    """One fixed-point step on ``state = (E_p, E_v, E_psi, E_r, w, w_psi)``.

    Returns the new state, the ultimate bounds, the disturbance and the force bound.
    """
    bounds = ErrorBounds(*(float(x) for x in state[:4]))
    force = _force(prob, bounds, impl)
    dist = lag_disturbance(
        prob.params,
        prob.envelope,
        prob.tube,
        prob.gains,
        impl,
        lam=prob.lam,
        sigma=prob.sigma,
        jerk=prob.jerk,
        force=force,
        bounds=bounds,
        yaw_jerk=prob.yaw_jerk,
        lag_channel=channel,
        previous=(float(state[4]), float(state[5])),
    )
    out: list[float] = []
    ult: list[float] = []
    for cert, w, v0 in zip(certs, (dist.position, dist.heading), start, strict=True):
        floor = cert.gain * w * w / (2.0 * cert.beta)
        out += level_extent(cert.p, max(v0, floor))
        ult += level_extent(cert.p, floor)
    return np.array([*out, dist.position, dist.heading]), ErrorBounds(*ult), dist, force


def _fits(prob: ImplementationProblem, b: ErrorBounds) -> bool:
    return b.heading < MAX_HEADING_ERROR and envelope_margins(prob.tube, b, prob.envelope).ok


#: What decides that an implementation is not covered: the stability limit of the lagged loops (no
#: decay is certified at ``sample_time + delay``), the envelope (the error bounds that the hold, the
#: delay and the noise leave do not fit it, or do not settle) or the actuators (the forces of those
#: errors exceed them).
GOVERNORS = ("stability", "envelope", "actuators")


@dataclass(frozen=True)
class LagBounds:
    """The outcome of :func:`bound_errors` (bounds in m, m/s, rad, rad/s; ``None`` when not covered).

    Attributes
    ----------
    covers : bool
        The error bounds are a verified fixed point inside the envelope (and the forces within
        the actuators).
    reasons : tuple of str
        Why not (empty when it covers).
    governed_by : str or None
        Which of :data:`GOVERNORS` decides when it does not cover (``None`` when it covers).
    decay_rate : float or None
        Rate (1/s) of the ISS certificates (the smaller of the two).
    bounds : ErrorBounds or None
        Bounds of the errors over the whole run.
    ultimate : ErrorBounds or None
        Bounds the errors enter and stay in as ``t -> inf``.
    thrust : ThrustBounds or None
        Bound of the commanded forces (N, N, N m).
    disturbance : LagDisturbance or None
        Bounds of the disturbances at the fixed point.
    certificates : tuple of LagResult
        The position and heading certificates (empty when none is verified).
    """

    covers: bool
    reasons: tuple[str, ...]
    governed_by: str | None = None
    decay_rate: float | None = None
    bounds: ErrorBounds | None = None
    ultimate: ErrorBounds | None = None
    thrust: ThrustBounds | None = None
    disturbance: LagDisturbance | None = None
    certificates: tuple[LagResult, ...] = ()

    def fields(self) -> dict[str, Any]:
        """The certificate fields this outcome decides."""
        return {
            "decay_rate": self.decay_rate,
            "bounds": self.bounds,
            "ultimate": self.ultimate,
            "thrust": self.thrust,
            "covers": self.covers,
            "reasons": self.reasons,
            "governed_by": self.governed_by,
            "disturbance": self.disturbance,
            "certificates": self.certificates,
        }


def bound_errors(prob: ImplementationProblem, impl: Implementation, start: ErrorBounds, channel: bool) -> LagBounds:
    """ISS certificates at the declared lag and the verified fixed point of the error bounds.

    Parameters
    ----------
    prob : ImplementationProblem
        The configuration (model, envelope, tube, gains, sigma, actuators).
    impl : Implementation
        Sample time, delay and measurement-noise bounds.
    start : ErrorBounds
        Bounds of the errors at ``t = 0`` (m, m/s, rad, rad/s).
    channel : bool
        The drift feedforward's dependence on the velocity error's change is a norm-bounded
        term of the position LMI (``q2``); otherwise it is part of the disturbance, bounded
        through the body accelerations.
    """
    lag = impl.max_lag
    loops = prob.lag_loops(channel)
    rates = [ISS_DECAY_FRACTION * decay_at(loop, lag) for loop in loops]
    certs = tuple(
        iss_certificate(loop, lag, beta, np.diag([loop.k, 1.0])) if beta > 0 else None
        for loop, beta in zip(loops, rates, strict=True)
    )
    if certs[0] is None or certs[1] is None:
        return LagBounds(False, (f"no decay rate is certified at sample_time + delay = {lag:.4g} s",), "stability")
    pair = (certs[0], certs[1])
    v0 = (box_level(pair[0].p, start.position, start.velocity), box_level(pair[1].p, start.heading, start.yaw_rate))
    # the fixed point runs on (error bounds, disturbance bounds): the body accelerations that
    # bound the disturbance depend on the disturbance itself
    state = np.array([*level_extent(pair[0].p, v0[0]), *level_extent(pair[1].p, v0[1]), 0.0, 0.0])
    reasons: list[str] = []
    for _ in range(FIXED_POINT_ITERATIONS):
        if not _fits(prob, _bounds(state)):
            reasons.append(
                "the error bounds leave the envelope: the implementation's disturbance is too large "
                f"(last bounds |e| <= {state[0]:.3g} m, |e'| <= {state[1]:.3g} m/s, |e_psi| <= {state[2]:.3g} rad)"
            )
            break
        new = _step(prob, impl, pair, v0, state, channel)[0]
        if np.all(new <= state * (1.0 + 1e-12) + 1e-300):
            break
        state = np.maximum(new, state)
    else:
        reasons.append(f"the error bounds did not settle in {FIXED_POINT_ITERATIONS} iterations")
    if reasons:
        return LagBounds(False, tuple(reasons), "envelope", decay_rate=min(c.beta for c in pair), certificates=pair)
    wide_state = state * (1.0 + FIXED_POINT_RTOL)
    wide = _bounds(wide_state)
    new, ult, dist, force = _step(prob, impl, pair, v0, wide_state, channel)
    governed_by = None
    if not (np.all(new <= wide_state) and _fits(prob, wide)):
        reasons.append("the error bounds are not self-consistent (fixed-point check failed)")
        governed_by = "envelope"
    if not reasons and prob.actuators is not None and not prob.actuators.admits(force.as_tuple()):
        reasons.append(
            f"the commanded forces (|tau_x| <= {force.force_x:.4g} N, |tau_y| <= {force.force_y:.4g} N, "
            f"|tau_psi| <= {force.moment:.4g} N m, noise included) exceed the actuators"
        )
        governed_by = "actuators"
    ok = not reasons
    return LagBounds(
        ok,
        tuple(reasons),
        governed_by,
        decay_rate=min(c.beta for c in pair),
        bounds=wide if ok else None,
        ultimate=ult if ok else None,
        thrust=force,
        disturbance=dist,
        certificates=pair,
    )


def _bounds(state: FloatArray) -> ErrorBounds:
    """The error bounds of a fixed-point state (m, m/s, rad, rad/s)."""
    return ErrorBounds(*(float(x) for x in state[:4]))


METHOD = (
    "input-delay approach: Lyapunov-Krasovskii functional with Jensen's bound for every measurement "
    "age in [0, sample_time + delay] (Fridman 2014), per-vehicle position (||D|| <= sigma, S-procedure) "
    "and heading (vertex damping) loops; held-command, reference and noise terms as a bounded "
    "disturbance (ISS); bounds by a verified fixed point; exact reference by python-control c2d"
)


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
    """:func:`certified_lag` of both loops and :func:`exact_limit` of their nominal members.

    Parameters
    ----------
    loops : tuple of LagLoop
        Position and heading loops.
    nominal_dampings : tuple of float
        Velocity coefficient ``a`` (1/s) of each loop's nominal member.
    delay : float
        Declared delay (s) for the exact limit.
    """
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
    governed_by : str or None
        Which of :data:`GOVERNORS` decides that it does not cover (``None`` when it covers).
    disturbance : LagDisturbance or None
    certificates : tuple of LagResult
        The verified position and heading certificates (empty when none).
    method : str
        The method, in words (:data:`METHOD`).
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
    governed_by: str | None = None

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
            "governed_by": self.governed_by,
            "method": self.method,
        }


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
    limits = limits or lag_limits(prob.loops, prob.nominal_dampings, impl.delay)
    lag = impl.max_lag
    if lag > limits.lag:
        room = limits.lag - impl.delay
        # a necessary condition, not advice: the sample time that is covered (noise, envelope and
        # start included) is searched by the implementation part below this limit
        head = (
            f"sample_time + delay = {lag:.4g} s exceeds the certified {limits.lag:.4g} s (this certificate's "
            "Lyapunov-Krasovskii lag)"
        )
        if room > 0.0:
            why = (
                f"{head}: at delay {impl.delay:.4g} s the loops are certified stable for sample times <= {room:.4g} s "
                f"only (exact nominal limit {limits.exact_sample_time:.4g} s)"
            )
        else:
            why = f"{head}; the delay alone uses it all: set [implementation] delay < {limits.lag:.4g} s"
        return _certificate(impl, limits, LagBounds(False, (why,), "stability"))
    first = bound_errors(prob, impl, start, True)
    return _certificate(impl, limits, first if first.covers else bound_errors(prob, impl, start, False))


def _certificate(impl: Implementation, limits: LagLimits, b: LagBounds) -> ImplementationCertificate:
    return ImplementationCertificate(
        implementation=impl,
        max_sample_time=max(limits.lag - impl.delay, 0.0),
        max_delay=max(limits.lag - impl.sample_time, 0.0),
        exact_max_sample_time=limits.exact_sample_time,
        decay_rate=b.decay_rate,
        bounds=b.bounds,
        ultimate=b.ultimate,
        thrust=b.thrust,
        covers=b.covers,
        reasons=b.reasons,
        disturbance=b.disturbance,
        certificates=b.certificates,
        governed_by=b.governed_by,
    )


__all__ = [
    "FIXED_POINT_ITERATIONS",
    "FIXED_POINT_RTOL",
    "GOVERNORS",
    "ISS_DECAY_FRACTION",
    "METHOD",
    "ImplementationCertificate",
    "LagBounds",
    "LagLimits",
    "bound_errors",
    "certify_implementation",
    "lag_limits",
]
