"""The certificate of the controller as it runs: sampled, held, delayed, noisy.

Per vehicle and per loop (position, heading) the lagged law is certified by a
Lyapunov-Krasovskii functional (:mod:`auv_hinf.design.lmi.sampled`) for every measurement age
up to ``T = sample_time + delay``; the implementation's remaining effects are a bounded
disturbance (:mod:`auv_hinf.certification.lag_terms`) whose size depends on the error bounds
through the force the law commands; the error bounds are a verified fixed point
(:mod:`auv_hinf.certification.lag_bounds`). The envelope margins of those bounds, the LMI and
(when declared) the actuators decide ``covers``; :func:`lag_limits` gives the certified and the
exact sample-time limits (:mod:`auv_hinf.certification.sampling`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from auv_hinf.certification.lag_bounds import LagBounds, bound_errors
from auv_hinf.certification.lag_problem import ImplementationProblem
from auv_hinf.certification.lag_terms import LagDisturbance
from auv_hinf.certification.margins import ErrorBounds
from auv_hinf.certification.sampling import certified_lag, exact_limit
from auv_hinf.certification.thrust import ThrustBounds
from auv_hinf.design.lmi.sampled import LagLoop, LagResult
from auv_hinf.models.implementation import Implementation

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
        why = (
            f"sample_time + delay = {lag:.4g} s exceeds the certified {limits.lag:.4g} s: at delay {impl.delay:.4g} s "
            f"the sample time must be <= {max(limits.lag - impl.delay, 0.0):.4g} s (exact nominal limit "
            f"{limits.exact_sample_time:.4g} s); lower the gains' bandwidth or sample faster"
        )
        return _certificate(impl, limits, LagBounds(False, (why,)))
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
    )


__all__ = ["ImplementationCertificate", "LagLimits", "certify_implementation", "lag_limits"]
