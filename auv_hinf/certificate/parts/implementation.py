"""The implementation part of a certificate: the design's gains run as configured in ``[implementation]``.

:func:`implementation_summary` certifies the sampled, delayed, noisy loop of the design point
(:mod:`auv_hinf.implementation.sampled_data`) from the configured start, and says whether the
declared implementation is covered. The continuous default reports the limits too (how fast
the law must be sampled), and covers exactly when the continuous certificates do.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np

from auv_hinf.certificate.deployed import mission_jerks
from auv_hinf.certificate.design_point import DesignPoint, initial_states
from auv_hinf.certificate.part import FORMATION_LAW, ControlLaw, PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.reason import Reason, Setting, upper
from auv_hinf.closed_loop.coverage import initial_errors
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.exceptions import AuvHinfError
from auv_hinf.implementation.lag import ImplementationProblem
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.implementation.sampled_data import (
    ImplementationCertificate,
    LagLimits,
    certify_implementation,
    lag_limits,
)
from auv_hinf.implementation.sampled_loop import control_period
from auv_hinf.mission.margins import ERROR_UNITS, ErrorBounds
from auv_hinf.numerics.bisection import bisect
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR

#: The part's registry name and JSON key.
PART = "implementation"
#: Relative width at which the search for the largest covered sample time stops.
COVERED_SEARCH_RTOL = 0.05
#: The search starts at this fraction of the certified sample-time limit.
COVERED_SEARCH_FLOOR = 1e-3

#: What decides that the declared implementation is not covered, in words: the implementation certificate's own
#: :data:`~auv_hinf.implementation.sampled_data.GOVERNORS`, the declared box or current it does not cover yet, or
#: the missing closed-loop certificate it extends.
GOVERNOR_WORDS = {
    "stability": "the stability limit",
    "envelope": "the envelope",
    "actuators": "the actuators",
    "uncertainty": "the declared uncertainty",
    "closed_loop": "the closed loop",
    "computation": "the certificate's computation",
}

#: What the implementation certificate does not yet cover, said when it would matter.
BOX_NOT_COVERED = (
    "the implementation certificate covers the controller's own model as the plant: the declared "
    "[uncertainty] box / [disturbance] current is judged for the sampled law by the composed certificate "
    "(and for the continuous law by the robust one)"
)


def implementation_problem(point: DesignPoint, cert: ClosedLoopCertificate) -> ImplementationProblem:
    """The implementation problem of ``point`` along its mission, with the closed loop's sigma and c-range.

    Parameters
    ----------
    point : DesignPoint
        The design point (configuration, gains, tube, lambda).
    cert : ClosedLoopCertificate
        Its closed-loop certificate (the region's sigma and heading damping range).
    """
    cfg = point.config
    jerk, yaw_jerk = reference_jerks(point)
    return ImplementationProblem(
        params=cfg.vehicle,
        envelope=cfg.envelope,
        tube=point.tube,
        gains=point.require_gains(),
        lam=point.lam,
        sigma=cert.region.sigma,
        c_range=cert.region.c_range,
        jerk=jerk,
        actuators=cfg.force_limits,
        yaw_jerk=yaw_jerk,
    )


def reference_jerks(point: DesignPoint) -> tuple[float, float]:
    """Bounds of every vehicle's ``|p_d'''|`` (m/s^3) and of ``|psi_d'''|`` (rad/s^3) along the raw mission.

    See :func:`~auv_hinf.certificate.deployed.mission_jerks`.

    Parameters
    ----------
    point : DesignPoint
        The design point (its mission, frame and offsets).
    """
    return mission_jerks(point.mission, point.offsets, point.config.frame)


def start_errors(point: DesignPoint) -> ErrorBounds:
    """Largest errors of the configured start against the raw mission at ``t = 0`` (m, m/s, rad, rad/s).

    Parameters
    ----------
    point : DesignPoint
        The design point (its configured initial states and fleet reference).
    """
    e, de, epsi, depsi = initial_errors(point.fleet(), initial_states(point))
    return ErrorBounds(
        float(np.hypot(e[..., 0], e[..., 1]).max()),
        float(np.hypot(de[..., 0], de[..., 1]).max()),
        float(np.abs(epsi).max()),
        float(np.abs(depsi).max()),
    )


@dataclass(frozen=True)
class ImplementationSummary:
    """What ``certify`` reports about the implementation.

    Attributes
    ----------
    implementation : Implementation
        The declared one.
    certificate : ImplementationCertificate or None
        ``None`` when there is no closed-loop certificate to extend (see ``reasons``).
    covers : bool
        The declared implementation is certified from the configured start.
    reasons : tuple of str
    covered_sample_time : float or None
        When the declared implementation is not covered: the largest sample time (s) that is,
        with the declared delay and noise (``None``: none is, or not searched).
    governed_by : str or None
        What decides that it is not covered, a key of :data:`GOVERNOR_WORDS` (``None``: covered).
    searched : bool
        The largest covered sample time was searched for (``covered_sample_time`` ``None`` then
        means that none is covered).
    """

    implementation: Implementation
    certificate: ImplementationCertificate | None
    covers: bool
    reasons: tuple[str, ...]
    covered_sample_time: float | None = None
    governed_by: str | None = None
    searched: bool = False

    def to_dict(self) -> dict[str, Any]:
        """The ``implementation`` object of ``auv-hinf certify --json``.

        The error and ultimate bounds are the exact solution's, raised to the integrator's
        numerical floor (:data:`~auv_hinf.numerics.integrators.NUMERICAL_FLOOR`, 1e-5 in each
        unit) so that a simulated run is never measured above them.
        """
        base: dict[str, Any] = (
            self.certificate.to_dict()
            if self.certificate is not None
            else {
                **self.implementation.to_dict(),
                "continuous": self.implementation.continuous,
                "max_sample_time": None,
                "max_delay": None,
                "exact_max_sample_time": None,
                "tightness": None,
                "decay_rate": None,
                "ultimate_bounds": None,
                "error_bounds": None,
            }
        )
        period = None if self.certificate is None else self.certificate.implementation.sample_time
        for key in ("error_bounds", "ultimate_bounds"):  # a simulated run meets them to the integrator's accuracy
            if base.get(key) is not None:
                base[key] = {k: max(v, NUMERICAL_FLOOR) for k, v in base[key].items()}
        return {
            **base,
            "numerical_floor": NUMERICAL_FLOOR,
            **self.implementation.to_dict(),
            "control_period": None if self.implementation.continuous else period,
            "covers": self.covers,
            "covered_sample_time": self.covered_sample_time,
            "searched_sample_time": self.searched,
            "governed_by": self.governed_by,
            "description": self.implementation.describe(),
            "reasons": list(self.reasons),
        }


def implementation_summary(
    point: DesignPoint,
    nominal: ClosedLoopCertificate | None,
    continuous_ok: bool,
    *,
    search: bool = True,
    horizon: float | None = None,
) -> ImplementationSummary:
    """Certify the declared implementation of ``point`` (see the module docstring).

    Parameters
    ----------
    point : DesignPoint
    nominal : ClosedLoopCertificate or None
        The continuous closed-loop certificate (its sigma and heading damping range are reused).
    continuous_ok : bool
        The continuous certificates (closed loop, robust when declared) hold: the verdict of the
        continuous default.
    search : bool
        When the declared implementation is not covered, search the largest sample time that is
        (a few more certificates).
    horizon : float, optional
        The run's horizon (s; default the configured one): with ``sample_time = 0`` and a delay
        or noise the law runs at a fine period that depends on it
        (:func:`~auv_hinf.implementation.sampled_loop.control_period`), and the certificate is for
        that period.
    """
    declared = point.config.implementation
    impl = declared
    if not declared.continuous and declared.sample_time == 0.0:
        period = control_period(declared, horizon if horizon is not None else point.config.simulation.horizon)
        impl = replace(declared, sample_time=period)
    if point.gains is not None and point.gains.integral:  # continuous only (the config refuses the rest)
        why = () if continuous_ok else ("the continuous certificates do not hold",)
        return ImplementationSummary(declared, None, continuous_ok, why, governed_by="closed_loop" if why else None)
    if nominal is None or point.gains is None:
        why = ("no closed-loop certificate to extend to the implementation",)
        return ImplementationSummary(impl, None, False, why, governed_by="closed_loop")
    try:
        prob, start = implementation_problem(point, nominal), start_errors(point)
        limits = lag_limits(prob.loops, prob.nominal_dampings, impl.delay)
        cert = certify_implementation(prob, impl, start, limits)
        if impl.continuous:
            return ImplementationSummary(declared, cert, continuous_ok, ())
        covered = None if cert.covers or not search else covered_sample_time(prob, impl, start, limits)
    except AuvHinfError as exc:
        why = (f"implementation not certified: {exc}",)
        return ImplementationSummary(declared, None, False, why, governed_by="computation")
    reasons = list(cert.reasons)
    if covered is not None:
        reasons.append(
            f"with delay {impl.delay:.4g} s and this noise, sample times up to {covered:.4g} s "
            f"({1.0 / covered:.3g} Hz) are covered"
        )
    elif not cert.covers and search:
        reasons.append(no_sample_time_covered(impl))
    if point.declared:
        reasons.append(BOX_NOT_COVERED)
    covers = cert.covers and not point.declared
    governed_by = None if covers else (cert.governed_by or "uncertainty")
    searched = search and not cert.covers
    return ImplementationSummary(declared, cert, covers, tuple(reasons), covered, governed_by, searched)


def no_sample_time_covered(impl: Implementation) -> str:
    """Why no sample time is covered, naming only what is declared."""
    declared = []
    if impl.delay > 0.0:
        declared.append(f"[implementation] delay ({impl.delay:.4g} s)")
    noise = impl.noise
    for key, unit in ERROR_UNITS.items():  # the bounds of [implementation.noise] share the errors' names
        value = getattr(noise, key)
        if value > 0.0:
            declared.append(f"[implementation.noise] {key} ({value:.4g} {unit})")
    if declared:
        return f"no sample time is covered with this delay and noise on this mission: reduce {' or '.join(declared)}"
    return (
        "no sample time is covered on this mission, even without delay or noise: the gains' continuous "
        "certificate leaves no margin for the hold"
    )


def covered_sample_time(
    prob: ImplementationProblem, impl: Implementation, start: ErrorBounds, limits: LagLimits
) -> float | None:
    """Largest sample time (s) covered with ``impl``'s delay and noise, by bisection (``None``: none).

    Coverage is not provably monotone in the sample time, so the answer is a bisection
    estimate of the boundary, and only its covered end is returned: that value itself is
    certified (the certificate at it covers).

    Parameters
    ----------
    prob : ImplementationProblem
        The configuration's implementation problem.
    impl : Implementation
        The declared implementation (its delay and noise are kept, its sample time varied).
    start : ErrorBounds
        Largest start errors (m, m/s, rad, rad/s).
    limits : LagLimits
        The loops' lag limits; the search runs up to ``limits.lag - impl.delay``.
    """
    hi = max(limits.lag - impl.delay, 0.0)
    if hi <= 0.0:
        return None

    def covers(h: float) -> bool:
        return certify_implementation(prob, replace(impl, sample_time=h), start, limits).covers

    lo = hi * COVERED_SEARCH_FLOOR
    if not covers(lo):
        return None
    return bisect(covers, lo, hi, rtol=COVERED_SEARCH_RTOL, geometric=True)[0]


def implementation_sweep(
    point: DesignPoint, sample_times: list[float], delay: float = 0.0, noise: MeasurementNoise | None = None
) -> list[ImplementationCertificate]:
    """The implementation certificate of ``point`` at each sample time (s), delay (s) and noise fixed.

    For design studies (notebook ``08_implementation``): decay rate and bounds against the sample time.

    Parameters
    ----------
    point : DesignPoint
        The design point.
    sample_times : list of float
        Sample times (s).
    delay : float
        Delay (s), the same for each.
    noise : MeasurementNoise, optional
        Measurement-noise bounds (default exact measurements).

    Raises
    ------
    DesignError
        When the design has no closed-loop certificate to extend.
    """
    nominal = closed_loop_for(point)
    prob, start = implementation_problem(point, nominal), start_errors(point)
    limits = lag_limits(prob.loops, prob.nominal_dampings, delay)
    base = Implementation(delay=delay, noise=noise or MeasurementNoise())
    return [certify_implementation(prob, replace(base, sample_time=h), start, limits) for h in sample_times]


@dataclass(frozen=True)
class ImplementationPart:
    """The controller as it runs (``[implementation]``): sampled, held, delayed and noisy.

    It always reports the limits of the design's gains (how fast they must be sampled); it
    applies, and decides, only when a sampled, delayed or noisy implementation is declared.
    """

    name: str = PART
    key: str | None = PART
    #: The fully actuated formation law only (with ``[guidance]`` the assembly does not evaluate it).
    laws: tuple[ControlLaw, ...] = FORMATION_LAW
    #: What covers the implementation when the part's law does not run, by the law that runs.
    idle_notes: ClassVar[dict[ControlLaw, str]] = {
        "guidance": "the guidance part judges the cascade at the declared sample time, delay and noise",
    }

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The implementation summary of ``ctx.point`` on the closed-loop part's certificate."""
        point = ctx.point
        loop = ctx.detail("closed_loop")
        nominal = None if loop is None else loop.certificate
        impl = implementation_summary(point, nominal, continuous_ok=ctx.holds_so_far())
        declared = not point.config.implementation.continuous
        c, run = impl.certificate, impl.implementation
        binding = None
        if declared and not impl.covers and c is not None:
            binding = (
                f"implementation (sample time {run.sample_time:.3g} s, delay {run.delay:.3g} s; "
                f"certified sample time up to {c.max_sample_time:.3g} s)"
            )
        if not declared or impl.covers:
            bound = None if not declared or c is None or c.bounds is None else float(c.bounds.position)
            return Verdict(
                self.name, True, declared, (), impl.to_dict(), binding=binding, detail=impl, position_bound=bound
            )
        # a sampled formation law is judged by the composed certificate first: this one only stands in for it
        # when it does not cover, and its own limits are not the deployed loop's, so its covered sample time
        # is no answer there (the composed part refuses at it too, and gives its own)
        covered = None if run.sampled else impl.covered_sample_time
        own = " by its own certificate (the composed certificate judges the deployed loop)" if run.sampled else ""
        why = Reason(
            self.name,
            "not_covered",
            f"implementation not covered{own}: " + "; ".join(impl.reasons),
            channel="sample_time",
            value=run.sample_time,
            limit=None if c is None else c.max_sample_time,
            settings=() if covered is None else (Setting("implementation", "sample_time", covered),),
        )
        return Verdict(self.name, False, True, (why,), impl.to_dict(), binding=binding, detail=impl)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The implementation, its limits, its bounds and one verdict with what governs it (s, Hz, 1/s, m, rad).

        The stability limit says what it is the largest of (the loops alone, at the declared delay), the
        covered sample time what it is covered with (this delay and noise, this mission); a declared
        implementation gets one verdict line, naming what decides it. The continuous default gets none:
        it decides nothing (the continuous certificates do).
        """
        f = figures
        if f is None:
            return []
        declared = not f["continuous"]
        described = f.get("description") or f"sample time {f['sample_time']:g} s, delay {f['delay']:g} s"
        out = [f"  implementation            {described}"]
        # a covering composed certificate prints its own timing (certified and exact limits)
        if f["max_sample_time"] is not None and f.get("covered_by") is None:
            ex, tight = f["exact_max_sample_time"], f["tightness"]
            vs = "" if tight is None else f"; {tight:.2f} of the exact nominal limit {ex:.4g} s"
            if f["max_sample_time"] > 0.0 and f["max_delay"] > 0.0:
                limit = (
                    f"sample time <= {f['max_sample_time']:.4g} s, the largest at which the error loops alone (no "
                    f"noise, no envelope) are certified stable with delay {f['delay']:.4g} s{vs}; delay <= "
                    f"{f['max_delay']:.4g} s at sample time {f['sample_time']:.4g} s"
                )
            else:  # the declared delay or sample time alone uses the certified total lag up: no vacuous '<= 0 s'
                used_up = [f["max_sample_time"] <= 0.0, f["max_delay"] <= 0.0]
                alone = " and ".join(x for x, up in zip(("the delay", "the sample time"), used_up, strict=True) if up)
                each = "each reach" if all(used_up) else "alone reaches"
                limit = (
                    f"none with delay {f['delay']:.4g} s and sample time {f['sample_time']:.4g} s: {alone} {each} "
                    "the total lag at which the error loops are certified stable (below)"
                )
            out.append(f"  stability limit (LK)      {limit}")
        b, u = f["error_bounds"], f["ultimate_bounds"]
        if declared and b is not None and u is not None:
            out.append(
                f"  errors (whole run)        |e| <= {upper(b['position'], 3)} m, "
                f"|e'| <= {upper(b['velocity'], 3)} m/s, "
                f"|e_psi| <= {upper(b['heading'], 3)} rad, |e_r| <= {upper(b['yaw_rate'], 3)} rad/s "
                f"(decay {f['decay_rate']:.3g} 1/s)"
            )
            out.append(
                f"  ultimate bounds           |e| <= {upper(u['position'], 3)} m, "
                f"|e'| <= {upper(u['velocity'], 3)} m/s, "
                f"|e_psi| <= {upper(u['heading'], 3)} rad, |e_r| <= {upper(u['yaw_rate'], 3)} rad/s"
            )
        if not declared:
            return out
        covered = _covered_line(f)
        return [*out, *([covered] if covered else []), _verdict_line(f)]

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Does the implementation certificate cover this sampled, delayed or noisy run (a condition)?

        Its bounds are about starts measured against the raw mission, so a run that needs a
        blended start is not covered by it.
        """
        point = ctx.point
        if point.config.implementation.continuous:
            return None
        earlier = ctx.checks.get("closed_loop")
        cert, cov = (None, None) if earlier is None else earlier.detail
        impl = implementation_summary(point, cert, continuous_ok=False, search=False, horizon=ctx.horizon)
        if cov is not None and cov.blend_time is not None:
            why = (
                "the implementation certificate covers starts on the raw mission; this start needs a blended reference"
            )
            impl = replace(impl, covers=False, reasons=(*impl.reasons, why))
        notes = () if impl.covers else ("implementation not covered: " + "; ".join(impl.reasons),)
        return RunCheck(self.name, "condition", True, impl.covers, "; ".join(impl.reasons), notes, detail=impl)


def _covered_line(f: Mapping[str, Any]) -> str | None:
    """The largest sample time covered with the declared delay and noise on this mission, when it was searched."""
    h, with_this = f.get("covered_sample_time"), f"with this delay ({f['delay']:.4g} s) and noise, on this mission"
    if f["covers"] or (h is None and not f.get("searched_sample_time")):
        return None
    if h is None and not f["sample_time"]:  # a continuous law with a delay or noise
        return f"  covered sample time       none: not even the continuous law (no hold) is covered {with_this}"
    if h is None:
        return f"  covered sample time       none: no sample time is covered {with_this}"
    return f"  covered sample time       <= {h:.4g} s ({1.0 / h:.3g} Hz): the largest covered {with_this}"


def _verdict_line(f: Mapping[str, Any]) -> str:
    """The one verdict of a declared implementation: yes, or NO with what governs it and why."""
    if f["covers"]:
        by = f.get("covered_by")
        return "  implementation covered    yes" + (f" (by the {by} certificate)" if by else "")
    first = (f["reasons"] or ["not certified"])[0]
    governor = GOVERNOR_WORDS.get(f.get("governed_by") or "")
    if governor is None:  # a record written before the verdicts named what governs them
        return f"  implementation covered    NO: {first}"
    stable = f["max_sample_time"] is not None and f["sample_time"] <= f["max_sample_time"]
    held = f"sample time {f['sample_time']:.4g} s" if f["sample_time"] else "continuous law"
    within = f" ({held}, within the stability limit)" if stable else ""
    return f"  implementation covered    NO, governed by {governor}: {first}{within}"


__all__ = [
    "BOX_NOT_COVERED",
    "COVERED_SEARCH_FLOOR",
    "COVERED_SEARCH_RTOL",
    "GOVERNOR_WORDS",
    "ImplementationSummary",
    "covered_sample_time",
    "implementation_problem",
    "implementation_summary",
    "implementation_sweep",
    "reference_jerks",
    "start_errors",
]
