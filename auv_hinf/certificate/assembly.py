"""Which constraint binds a certificate, and the force bounds it proves.

:func:`binding_constraint` names what limits the certified design (the implementation, the
actuators or the envelope); :func:`certified_peaks` lists the thrust bounds the certificate
proves (nominal region, the checked shaped start, the robust set).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import control as ct

from auv_hinf.certificate.design_point import design_point, formation_offsets, mission_reference
from auv_hinf.certificate.document import load_certificate, save_certificate
from auv_hinf.certificate.parts.actuators import ActuatorCheck, check_actuators
from auv_hinf.certificate.parts.closed_loop import ClosedLoopSummary, closed_loop_summary
from auv_hinf.certificate.parts.implementation import ImplementationSummary, implementation_summary
from auv_hinf.certificate.parts.robust import RobustSummary, robust_summary
from auv_hinf.certificate.text import certificate_text
from auv_hinf.config.settings import FormationConfig
from auv_hinf.design.crosscheck import CrosscheckReport, crosscheck
from auv_hinf.design.jacobi_sigma import jacobi_sigma_bounds
from auv_hinf.design.sigma import SigmaBounds
from auv_hinf.design.theorem1 import GainDesign, Theorem1Conditions, position_loop, theorem1_conditions
from auv_hinf.exceptions import DesignError
from auv_hinf.law.formation_law import MotionSource, VehicleLaw
from auv_hinf.law.gains import Gains
from auv_hinf.law.interconnect import fleet_closed_loop, formation_controller
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.vehicle import VehicleParams

#: An actuator channel counts as the binding constraint when the certified peak reaches this
#: share of its limit (the region is shrunk to fit the limits, so a binding channel sits at 1).
ACTUATOR_BINDING_RATIO = 0.99


def binding_constraint(
    act: ActuatorCheck, rob: RobustSummary, loop: ClosedLoopSummary | None, impl: ImplementationSummary
) -> str | None:
    """The constraint that limits the certified design: the implementation, actuators, the envelope, or none found."""
    c, run = impl.certificate, impl.implementation
    if not run.continuous and not impl.covers and c is not None:
        return (
            f"implementation (sample time {run.sample_time:.3g} s, delay {run.delay:.3g} s; "
            f"certified sample time up to {c.max_sample_time:.3g} s)"
        )
    if act.limits is not None and act.binding is not None and act.binding_ratio is not None:
        if act.binding_ratio >= ACTUATOR_BINDING_RATIO:
            return f"actuators ({act.binding}, {act.binding_ratio:.3g} of its limit)"
    margins = rob.certificate.margins if rob.declared and rob.certificate is not None else None
    if margins is None and loop is not None and loop.certificate is not None:
        margins = loop.certificate.region.margins
    if margins is not None:
        return f"operating envelope (smallest margin {margins.min:.3g})"
    return None


def certified_peaks(loop: ClosedLoopSummary | None, rob: RobustSummary) -> list[tuple[float, float, float]]:
    """The thrust bounds the certificate proves: nominal region, checked shaped start, robust set."""
    out = []
    if loop is not None and loop.certificate is not None:
        out.append(loop.certificate.thrust.as_tuple())
        if loop.shaped is not None and loop.shaped.covered and loop.shaped.thrust is not None:
            out.append(loop.shaped.thrust.as_tuple())
    c = rob.certificate
    if rob.declared and c is not None and c.thrust is not None:
        out.append(c.thrust.as_tuple())
    return out


#: Fleet size at which the certificate runs its full-size cross-check. With
#: ``A_lam = lam I`` every 2x2 channel is identical, so a larger problem checks nothing
#: new; the LMI compile time grows quickly with N (25 s at N = 20), so larger fleets are
#: checked at this size. Full-size checks up to N = 20 are in the tests and benchmarks.
CROSSCHECK_MAX_N = 6


#: Above this fleet size the Jacobi-coordinate search (matrix-free, O(N) per sample, about
#: 15-30 us per vehicle and sample) is cut to ``JACOBI_SEARCH_WORK // N`` samples, at least
#: :data:`LARGE_FLEET_JACOBI_SAMPLES`: about one second whatever N. Its upper bound
#: (cond(Phi) * sigma, closed form) is unaffected, only the witnessed lower bound gets coarser.
JACOBI_SEARCH_MAX_N = 12


JACOBI_SEARCH_WORK = 40_000


LARGE_FLEET_JACOBI_SAMPLES = 4


#: The small-gain margin ``(alpha - lam) - sigma_upper`` (1/s) must exceed
#: ``MARGIN_RTOL * (|lam| + sigma_upper)`` to certify: the margin is a difference of
#: quantities of that size, each known to ~1e-15 relative, so 1e-9 of the scale is far above
#: round-off and far below any margin a design would rely on. A margin at or below it is
#: "not certified (marginal)", decided by this rule and never by rounding. In particular
#: method "minimal" with the default gamma = 1/sigma_upper and alpha = 1/gamma + lam > 0 has
#: margin 0 in exact arithmetic (alpha - lam = 1/gamma = sigma_upper) and is always reported
#: marginal; when the clamp alpha = 0 is active the margin is |lam| - sigma_upper, a real one.
MARGIN_RTOL = 1e-9


@dataclass(frozen=True)
class Certificate:
    """Result of :func:`certify`.

    Attributes
    ----------
    config : FormationConfig
    lam : float
        Constant lambda (1/s).
    sigma : SigmaBounds
        Vehicle-coordinate bounds, used by the small-gain test: the nominal loop
        ``(lam - alpha) I`` is the same in every coordinate system (``docs/derivations/sigma.md``).
    sigma_jacobi : SigmaBounds
        Jacobi-coordinate bounds, reported for comparison.
    gamma : float
        ``1/sigma.upper`` unless overridden (s).
    theorem1 : Theorem1Conditions
        The hypotheses of Theorem 1 at ``(lam, gamma)``.
    designs : dict
        ``GainDesign`` per method, or ``None`` where the method is infeasible.
    alpha_used : float or None
        Gain of the configured method (1/s).
    small_gain_margin : float or None
        ``(alpha - lam) - sigma.upper`` (1/s): the small-gain margin, must be > 0. It is the
        decay rate of the velocity loop alone (``k1 = 0``), not of the full loop: see
        ``closed_loop.decay_rate``.
    position_loop_hinf : float or None
        Theorem 2 loop norm ``1/(alpha - lam)`` (s) for ``k1``.
    crosscheck : CrosscheckReport
    certified : bool
        The small-gain test, the cross-checks *and* the closed-loop certificate all pass.
    reasons : tuple of str
        Why it is not certified (empty when certified).
    closed_loop : ClosedLoopSummary or None
        Decay rate, start region, thrust and start coverage of the full error loop along the
        configured mission (``None`` when the small-gain test already fails).
    robust : RobustSummary or None
        The robust certificate for the declared ``[uncertainty]`` box and ``[disturbance]``
        current (:mod:`auv_hinf.certificate.parts.robust`); the nominal loop's values when nothing
        is declared.
    gains : Gains or None
        The gains that run: the ones every certificate above is about, that ``simulate`` uses
        and that :meth:`controller` exports (``None`` when the design gives none).
    actuators : ActuatorCheck or None
        The certified peak force against the declared ``[actuators]`` limits.
    implementation : ImplementationSummary or None
        The certificate of the controller as it runs (``[implementation]``: sampling, delay,
        noise): limits, decay, bounds and whether the declared implementation is covered.
    design : dict or None
        How the gains were chosen (:meth:`~auv_hinf.certificate.design_point.DesignPoint.summary`),
        with the binding constraint of the certificate.
    gain_source : {"theorem1", "robust"}
        Where ``gains`` come from: Theorem 1 (``alpha_used``, ``k1``, the heading poles) or the
        robust design.
    """

    config: FormationConfig
    lam: float
    sigma: SigmaBounds
    sigma_jacobi: SigmaBounds
    gamma: float
    theorem1: Theorem1Conditions
    designs: dict[str, GainDesign | None]
    alpha_used: float | None
    small_gain_margin: float | None
    position_loop_hinf: float | None
    crosscheck: CrosscheckReport
    certified: bool
    reasons: tuple[str, ...] = field(default_factory=tuple)
    closed_loop: ClosedLoopSummary | None = None
    robust: RobustSummary | None = None
    gains: Gains | None = None
    gain_source: str = "theorem1"
    actuators: ActuatorCheck | None = None
    design: dict[str, Any] | None = None
    implementation: ImplementationSummary | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (the ``auv-hinf certify --json`` layout)."""
        paper = self.designs.get("paper")
        return {
            "preset": self.config.name,
            "n": self.config.n,
            "lambda": self.lam,
            "sigma": {
                "upper": self.sigma.upper,
                "lower": self.sigma.lower,
                "coords": "vehicle",
                "method": self.sigma.method,
                "witness": self.sigma.witness.to_dict(),
            },
            "sigma_jacobi": {
                "upper": self.sigma_jacobi.upper,
                "lower": self.sigma_jacobi.lower,
                "method": self.sigma_jacobi.method,
                "jacobi": self.config.jacobi,
            },
            "certificate_coords": "vehicle",
            "gamma": self.gamma,
            "method": self.config.method,
            "alpha": {
                **{m: (None if d is None else d.alpha) for m, d in self.designs.items()},
                "used": self.alpha_used,
            },
            "paper_flags": [] if paper is None else list(paper.flags),
            "theorem1": self.theorem1.to_dict(),
            "small_gain_margin": self.small_gain_margin,
            "k1": self.config.k1,
            "position_loop_hinf": self.position_loop_hinf,
            "crosscheck_ok": self.crosscheck.ok,
            "crosscheck_n": self.crosscheck.n,
            "crosscheck_max_rel_diff": self.crosscheck.max_rel_diff,
            "certified": self.certified,
            "reasons": list(self.reasons),
            "envelope": self.config.envelope.to_dict(),
            "vehicle": self.config.vehicle.to_dict(),
            "closed_loop": None if self.closed_loop is None else self.closed_loop.to_dict(),
            "robust": None if self.robust is None else self.robust.to_dict(),
            "implementation": None if self.implementation is None else self.implementation.to_dict(),
            "gains": None if self.gains is None else {**self.gains.to_dict(), "source": self.gain_source},
            "actuators": None if self.actuators is None else self.actuators.to_dict(),
            "design": self.design,
        }

    def save(self, path: str | Path) -> Path:
        """Write the certificate as a versioned, complete JSON file; see :mod:`auv_hinf.certificate.document`.

        Returns
        -------
        Path
            The file written.
        """
        return save_certificate(self, path)

    @classmethod
    def load(cls, path: str | Path) -> Certificate:
        """Read a file written by :meth:`save` and restore the certificate exactly (no re-certification).

        Raises
        ------
        ConfigError
            Wrong format or version, invalid configuration, or an edited record.
        """
        return load_certificate(path, cls)

    def law(self) -> VehicleLaw:
        """The law this certificate is about: its :attr:`gains` on the configured model and thrust limit.

        Raises
        ------
        DesignError
            If the design gave no gains (see :attr:`reasons`).
        """
        if self.gains is None:
            raise DesignError(f"certificate of {self.config.name!r} has no gains: {'; '.join(self.reasons)}")
        cfg = self.config
        return VehicleLaw(params=cfg.vehicle, gains=self.gains, actuators=cfg.actuators)

    def controller(self, reference: MotionSource | None = None) -> ct.NonlinearIOSystem:
        """The certified law along the raw mission as a static python-control ``nlsys``.

        Inputs ``x[i], y[i], psi[i], u[i], v[i], r[i]``, outputs ``tau_x[i], tau_y[i],
        tau_psi[i]`` (N, N, N m); see :func:`auv_hinf.law.interconnect.formation_controller`.
        ``reference`` overrides the raw mission reference (e.g. a shaped start from
        :func:`~auv_hinf.certificate.run_plan.plan_run`).
        """
        return formation_controller(self.law(), reference or self._mission_fleet(), self.config.n)

    def closed_loop_system(
        self, reference: MotionSource | None = None, plant: VehicleParams | None = None
    ) -> ct.NonlinearIOSystem:
        """The closed loop as ``control.interconnect`` of the N plants and :meth:`controller`.

        No inputs; the state is the stacked fleet state (``(N, 6).ravel()``) and so are the
        outputs; see :func:`auv_hinf.law.interconnect.fleet_closed_loop`. ``plant``
        defaults to the nominal model ``config.vehicle`` (the one the nominal certificate covers).
        """
        cfg = self.config
        ref = reference or self._mission_fleet()
        return fleet_closed_loop(self.law(), ref, cfg.vehicle if plant is None else plant, cfg.n)

    def _mission_fleet(self) -> FleetReference:
        """Raw mission reference: formation offsets (in their frame) around the mission path, no shaping."""
        cfg = self.config
        return FleetReference(mission_reference(cfg), formation_offsets(cfg), None, cfg.frame)

    def summary(self) -> str:
        """Readable table (:func:`~auv_hinf.certificate.text.certificate_text`)."""
        return certificate_text(self)


def certify(config: FormationConfig, *, jacobi_samples: int = 5000, refine_jacobi: bool = False) -> Certificate:
    """Certify the configured design over its envelope.

    Steps: the design point (:func:`~auv_hinf.certificate.design_point.design_point`: lambda,
    the certified vehicle-coordinate sigma, ``gamma = 1/sigma_upper``, the three alphas and
    the gains that run); the Jacobi bounds for the record; Theorem 1 conditions; small-gain
    margin ``(alpha - lam) - sigma_upper > 0``; cross-checks; the Theorem 2 loop norm; the
    closed-loop certificate along the mission and the robust certificate of the declared box
    and current. ``refine_jacobi`` tightens the reported Jacobi bound by branch-and-bound
    (slow; the certificate itself uses vehicle coordinates).
    """
    point = design_point(config)
    lam, sig, gamma = point.lam, point.sigma, point.gamma
    if config.n > JACOBI_SEARCH_MAX_N:
        jacobi_samples = min(jacobi_samples, max(LARGE_FLEET_JACOBI_SAMPLES, JACOBI_SEARCH_WORK // config.n))
    sig_j = jacobi_sigma_bounds(
        config.vehicle,
        config.envelope,
        lam,
        config.transform,
        samples=jacobi_samples,
        refine_jacobi=refine_jacobi,
        progress=True,  # the bar appears only after jacobi_sigma.PROGRESS_DELAY
    )
    cond = theorem1_conditions(lam, gamma)
    designs = point.designs
    used = designs.get(config.method)
    alpha = None if used is None else used.alpha
    reasons = [] if used is not None else [r for r in point.reasons if not r.startswith("robust design")]
    margin = pos = None
    if alpha is not None:
        margin = (alpha - lam) - sig.upper
        margin_tol = MARGIN_RTOL * (abs(lam) + sig.upper)
        if config.method == "minimal" and config.gamma is None and alpha > 0:
            reasons.append(
                f"not certified (marginal): method 'minimal' with gamma = 1/sigma_upper has "
                f"small-gain margin 0 by construction (computed {margin:.4g} 1/s); set "
                "design.gamma below 1/sigma"
            )
        elif margin <= margin_tol:
            reasons.append(
                f"not certified (marginal): small-gain margin (alpha - lambda) - sigma_upper = "
                f"{margin:.4g} 1/s <= tolerance {margin_tol:.3g} 1/s: ||T||_inf * sigma must be < 1 "
                "strictly (set design.gamma below 1/sigma)"
            )
        if alpha > lam:
            pos = position_loop(lam, alpha, config.k1).hinf
    if config.method != "minimal" and not cond.all_ok:
        if cond.singular_case:
            reasons.append("Theorem 1 singular case |lambda| = 1/gamma - gamma")
        if not cond.lam_negative:
            reasons.append(f"lambda = {lam:.4g} is not negative")
    report = crosscheck(lam, gamma, min(config.n, CROSSCHECK_MAX_N), config.k1)
    if not report.ok:
        reasons.append(f"cross-check disagrees (max rel diff {report.max_rel_diff:.3g})")
    loop = None
    if config.robust:
        # the robust design replaces Theorem 1's gain: its verdict is the robust certificate's
        reasons = [r for r in reasons if r.startswith("cross-check")]
        reasons.extend(r for r in point.reasons if r.startswith("robust design"))
    if point.gains is not None and (config.robust or not reasons) and not point.gains.integral:
        loop = closed_loop_summary(point)  # integral action: the robust certificate is the verdict
        reasons.extend(loop.reasons)
    nominal = None if loop is None else loop.certificate
    rob = robust_summary(point, nominal=nominal)
    act = check_actuators(point, certified_peaks(loop, rob))
    if config.actuators is not None and not act.certified:
        reasons.append(f"actuators: {act.reason}")
    if rob.declared and not rob.covers:
        reasons.append(
            "robust certificate does not cover the declared [uncertainty] box and [disturbance] current: "
            + ("; ".join(rob.to_dict()["reasons"]) or "see robust")
        )
    impl = implementation_summary(point, nominal, continuous_ok=not reasons)
    if not config.implementation.continuous and not impl.covers:
        reasons.append("implementation not covered: " + "; ".join(impl.reasons))
    return Certificate(
        config=config,
        lam=lam,
        sigma=sig,
        sigma_jacobi=sig_j,
        gamma=gamma,
        theorem1=cond,
        designs=designs,
        alpha_used=alpha,
        small_gain_margin=margin,
        position_loop_hinf=pos,
        crosscheck=report,
        certified=not reasons,
        reasons=tuple(reasons),
        closed_loop=loop,
        robust=rob,
        gains=point.gains,
        gain_source=point.source,
        actuators=act,
        design={**point.summary(), "binding": binding_constraint(act, rob, loop, impl)},
        implementation=impl,
    )


__all__ = [
    "ACTUATOR_BINDING_RATIO",
    "CROSSCHECK_MAX_N",
    "JACOBI_SEARCH_MAX_N",
    "JACOBI_SEARCH_WORK",
    "LARGE_FLEET_JACOBI_SAMPLES",
    "MARGIN_RTOL",
    "Certificate",
    "binding_constraint",
    "certified_peaks",
    "certify",
]
