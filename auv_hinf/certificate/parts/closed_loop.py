"""The closed-loop part: the nominal certificate of the design's gains along the mission.

:func:`closed_loop_for` certifies the full error loop of the design's gains along its
mission; :func:`coverage_for` decides whether that certificate covers one run's start;
:func:`closed_loop_summary` is the part's result: decay rates, the start region and thrust
bounds along the configured mission, and the verdict on the configured start.
:class:`ClosedLoopPart` is the part of the certificate (:mod:`auv_hinf.certificate.part`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, cast

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import CHANNELS, actuator_shortfall
from auv_hinf.certificate.design_point import DesignPoint, initial_states, slot_states
from auv_hinf.certificate.part import FORMATION_LAW, ControlLaw, PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.reason import Reason, Setting, reason_from, upper
from auv_hinf.closed_loop.actuator_fit import mission_thrust, within_actuators
from auv_hinf.closed_loop.coverage import Coverage, StartMode, cover_start
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate, closed_loop_certificate
from auv_hinf.exceptions import AuvHinfError, DesignError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fit import ReferenceFit
from auv_hinf.mission.fleet import FleetReference, turn_radius_changes
from auv_hinf.models.envelope import Envelope

#: The part's registry name and JSON key.
PART = "closed_loop"
#: A heading range counts as the full circle when its width is 2 pi up to this relative
#: round-off (the default ``(-pi, pi)`` has width 2 pi exactly).
FULL_CIRCLE_RTOL = 1e-12


def full_heading_range(envelope: Envelope) -> None:
    """Raise unless the envelope's heading range is the full circle (no certificate promises a heading range).

    The certificates bound the errors, surge, sway and yaw rate, not the heading itself.

    Parameters
    ----------
    envelope : Envelope
        The declared envelope.

    Raises
    ------
    DesignError
        When ``envelope.psi`` is narrower than ``2 pi`` (its setting: the full circle).
    """
    width = envelope.psi[1] - envelope.psi[0]
    if width < 2.0 * math.pi * (1.0 - FULL_CIRCLE_RTOL):
        full = Setting("envelope", "psi", [-math.pi, math.pi])
        raise DesignError(
            f"envelope.psi = {list(envelope.psi)} rad is narrower than the full circle: the certificates bound "
            "surge, sway, yaw rate and the errors, not the heading itself, so they cannot promise a heading range "
            f"(declare the full circle, {full.words()})",
            kind="envelope",
            channel="psi",
            value=width,
            limit=2.0 * math.pi,
            settings=(("envelope", "psi", [-math.pi, math.pi]),),
        )


def mission_checks(point: DesignPoint) -> Gains:
    """The design's gains, after the checks every certificate needs: full heading range, mission in the envelope.

    Parameters
    ----------
    point : DesignPoint
        The design point.

    Raises
    ------
    DesignError
        As :func:`closed_loop_for`, for these checks.
    """
    cfg = point.config
    full_heading_range(cfg.envelope)
    gains = point.require_gains()
    fit = point.fit
    if not fit.ok:
        b = fit.binding
        raise DesignError(
            fit.reason(),
            kind="envelope",
            channel=None if b is None else b.channel,
            vehicle=None if b is None or cfg.frame != "path" else b.vehicle,
            value=None if b is None else b.margin,
            limit=0.0,
            settings=()
            if fit.smallest_radius is None
            else tuple(("reference", k, v) for k, v in turn_radius_changes(point.mission, fit.smallest_radius).items()),
        )
    return gains


def closed_loop_for(point: DesignPoint) -> ClosedLoopCertificate:
    """Closed-loop certificate of the design's gains along its mission (raises when there is none).

    With declared ``[actuators]`` the start region is shrunk until the certified thrust fits
    them (:func:`~auv_hinf.closed_loop.actuator_fit.within_actuators`).

    Parameters
    ----------
    point : DesignPoint
        The design point (configuration, gains, tube, lambda, sigma).

    Raises
    ------
    DesignError
        If there are no gains, the envelope's heading range is narrower than the full
        circle, some vehicle's desired motion leaves the envelope even at zero error (the
        message names the vehicle, the turn and the smallest turn radius that fits), the
        small-gain condition fails, the mission alone needs more force than the actuators give, or
        the gains have integral action (the robust certificate covers those).
    """
    cfg = point.config
    gains = mission_checks(point)
    if gains.integral:
        raise DesignError(
            "the nominal closed-loop certificate covers the paper's law; integral action is certified by the "
            "robust certificate only",
            kind="unsupported",
        )
    cert = closed_loop_certificate(cfg.vehicle, cfg.envelope, point.tube, gains, lam=point.lam, sigma=point.sigma.upper)
    if cfg.force_limits is None:
        return cert
    fitted = within_actuators(cert, cfg.vehicle, cfg.envelope, point.tube, gains, cfg.force_limits)
    if fitted is None:
        need = mission_thrust(cfg.vehicle, cfg.envelope, point.tube, gains).as_tuple()
        channel, ratio = cfg.force_limits.binding(need)
        k = CHANNELS.index(channel) if channel in CHANNELS else None
        raise DesignError(
            "no start region fits the actuators: even tracked exactly, the mission needs "
            + actuator_shortfall(cfg.force_limits, need),
            kind="thrust",
            channel=channel,
            value=ratio if k is None else need[k],
            limit=1.0 if k is None else cfg.force_limits.limits()[k],
        )
    return fitted


def coverage_for(
    point: DesignPoint, cert: ClosedLoopCertificate, initial: FloatArray, start: StartMode, *, progress: bool = True
) -> Coverage:
    """Coverage of the run of the design's configuration from ``initial`` in ``start`` mode (nominal plant).

    Parameters
    ----------
    point : DesignPoint
        The design point.
    cert : ClosedLoopCertificate
        Its closed-loop certificate.
    initial : ndarray, shape (N, 6)
        Initial states ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    start : {"shaped", "paper"}
        The start mode.
    progress : bool
        A search over blend times that runs longer than
        :data:`~auv_hinf.numerics.progress.PROGRESS_DELAY` shows a progress bar (stderr).
    """
    cfg = point.config
    return cover_start(
        cert,
        cfg.vehicle,
        cfg.envelope,
        point.require_gains(),
        point.mission,
        point.offsets,
        initial,
        start=start,
        frame=cfg.frame,
        blend_time=cfg.simulation.blend_time,
        actuators=cfg.force_limits,
        current=cfg.simulation.current,
        progress=progress,
    )


@dataclass(frozen=True)
class ClosedLoopSummary:
    """What :func:`~auv_hinf.certificate.assembly.certify` reports about the closed loop.

    Attributes
    ----------
    certificate : ClosedLoopCertificate or None
        Decay rates, start region and thrust over the region; ``None`` when the mission
        leaves the envelope even at zero error (see ``reasons``).
    shaped : Coverage or None
        Verdict on the configured start in the configured ``[simulation] start`` mode (``"shaped"``:
        the best blend found, ``"paper"``: the raw mission), as ``simulate`` runs it.
    declared_start : bool
        The configuration gives its own initial states (then the verdict requires them covered).
    reasons : tuple of Reason
        Why the closed loop is not certified (empty when it is).
    fit : ReferenceFit or None
        Per-vehicle verdict on the desired motion at zero error.
    mode : {"shaped", "paper"}
        The start mode :attr:`shaped` was judged in (``[simulation] start``).
    """

    certificate: ClosedLoopCertificate | None
    shaped: Coverage | None
    declared_start: bool
    reasons: tuple[Reason, ...]
    fit: ReferenceFit | None = None
    mode: StartMode = "shaped"

    @property
    def ok(self) -> bool:
        """The closed loop is certified."""
        return not self.reasons

    def start_bound(self) -> tuple[float | None, FleetReference | None]:
        """The sup over all ``t`` of the position error (m) the certificate proves for the configured start.

        With the reference it is measured against (the shaped start the coverage search chose, or the raw
        mission); ``(None, None)`` when the closed loop is not certified or does not cover the start. The
        nominal plant without current: the certificate's own model.
        """
        s = self.shaped
        if not self.ok or self.certificate is None or s is None or not s.covered:
            return None, None
        return float(s.bounds.position), s.reference

    @staticmethod
    def _fit_keys(fit: ReferenceFit) -> dict[str, Any]:
        """``reference_frame``, ``binding`` (vehicle, time, channel, edge, margin) and ``reference_fit``."""
        return {
            "reference_frame": fit.frame,
            "binding": None if fit.binding is None else fit.binding.to_dict(),
            "reference_fit": {**fit.to_dict(), "reason": fit.reason()},
        }

    def to_dict(self) -> dict[str, Any]:
        """The ``closed_loop`` object of ``auv-hinf certify --json``."""
        c, s = self.certificate, self.shaped
        forces = [] if c is None else [c.thrust.force_x, c.thrust.force_y]
        moments = [] if c is None else [c.thrust.moment]
        if s is not None and s.covered and s.thrust is not None:
            forces += [s.thrust.force_x, s.thrust.force_y]
            moments.append(s.thrust.moment)

        def radii(r: Any) -> dict[str, float]:
            return {
                "position_error": float(r.position),
                "velocity_error": float(r.velocity),
                "heading_error": float(r.heading),
                "yaw_rate_error": float(r.yaw_rate),
            }

        return {
            "decay_rate": None if c is None else c.rate,
            "position_decay_rate": None if c is None else c.position.rate,
            "heading_decay_rate": None if c is None else c.heading.rate,
            "region": None if c is None else radii(c.region.region),
            "single_axis_region": None if c is None else radii(c.region.single_axis),
            "region_error_bounds": None if c is None else radii(c.region.bounds),
            "thrust": None if c is None else c.thrust.to_dict(),
            # per vehicle: its own desired motion at zero error stays in the envelope (in the inertial
            # frame every vehicle's is the centre's); certificates saved before 0.3 hold no fit: one bool
            "reference_inside_envelope": c is not None if self.fit is None else list(self.fit.inside),
            **({} if self.fit is None else self._fit_keys(self.fit)),
            "max_force": max(forces) if forces else None,
            "max_moment": max(moments) if moments else None,
            "start_mode": self.mode,
            "covers_shaped_start": bool(s is not None and s.covered),
            "shaped_start": None if s is None else s.to_dict(),
            "shaped_start_note": (
                None
                if s is not None
                else "the default start (the fleet on its slots) could not be checked (see reasons)"
                if not self.declared_start
                else "the declared start could not be checked (see reasons)"
            ),
            "method": None if c is None else c.method,
            "certified": self.ok,
            "reasons": [r.message for r in self.reasons],
        }


#: The start mode that blends the reference from the start (:func:`~auv_hinf.mission.fleet.shaped_start`),
#: advised when the raw mission does not cover a declared start and the blend does.
SHAPED = Setting("simulation", "start", "shaped")


def _shaped_covers(point: DesignPoint, cert: ClosedLoopCertificate) -> bool:
    """The configured start is covered in ``"shaped"`` mode (a failed search counts as not covered)."""
    try:
        return coverage_for(point, cert, initial_states(point), "shaped").covered
    except AuvHinfError:
        return False


#: The answer that starts every vehicle on its slot, at zero error: the declared ``[simulation] initial`` removed.
ON_SLOTS = Setting("simulation", "initial", None)


def _slots_cover(point: DesignPoint, cert: ClosedLoopCertificate, mode: StartMode) -> bool:
    """The fleet started on its slots (:func:`~auv_hinf.certificate.design_point.slot_states`) is covered."""
    try:
        return coverage_for(point, cert, slot_states(point.fleet()), mode).covered
    except AuvHinfError:
        return False


def closed_loop_summary(point: DesignPoint) -> ClosedLoopSummary:
    """Certify the closed loop of the design point along its mission and check its configured start.

    The start ``simulate`` will run is checked, whatever the fleet size: a declared start
    (``simulation.initial``) enters the verdict; the default start is the fleet on its slots
    (:func:`~auv_hinf.certificate.design_point.initial_states`), at zero error, so the raw mission
    covers it without a blend and the check costs one tube. A declared start far from the
    slots builds per-vehicle tubes for the candidate blend times it tries, with a progress bar
    when that takes more than a few seconds (:func:`coverage_for`).

    Parameters
    ----------
    point : DesignPoint
        The design point.
    """
    cfg = point.config
    reasons: list[Reason] = []
    declared, mode = cfg.simulation.initial is not None, cfg.simulation.start
    try:
        cert = closed_loop_for(point)
    except AuvHinfError as exc:
        why = reason_from(PART, exc, "closed loop not certified: ")
        return ClosedLoopSummary(None, None, declared, (why,), point.fit, mode)
    try:
        shaped: Coverage | None = coverage_for(point, cert, initial_states(point), mode)
    except AuvHinfError as exc:
        shaped = None
        if declared:
            reasons.append(reason_from(PART, exc, "configured start: "))
    if declared and shaped is not None and not shaped.covered:
        message = f"configured start not covered: {shaped.reason.removeprefix('not covered: ')}"
        settings: tuple[Setting, ...] = ()
        if mode == "paper" and _shaped_covers(point, cert):
            settings = (SHAPED,)
            message += f"; with the reference blended from the start it is covered ({SHAPED.toml()})"
        elif _slots_cover(point, cert, mode):
            settings = (ON_SLOTS,)
            message += f"; the fleet started on its slots is covered ({ON_SLOTS.toml()})"
        reasons.append(Reason(PART, "start", message, settings=settings))
    return ClosedLoopSummary(cert, shaped, declared, tuple(reasons), point.fit, mode)


@dataclass(frozen=True)
class ClosedLoopPart:
    """The nominal closed loop along the mission: decay, start region, thrust, the configured start.

    It applies when the design has gains without integral action and the paper's certificate
    holds (or the gains are the robust design's); otherwise it reports nothing and the other
    parts decide.
    """

    name: str = PART
    key: str | None = PART
    #: The fully actuated formation law only (with ``[guidance]`` the assembly does not evaluate it).
    laws: tuple[ControlLaw, ...] = FORMATION_LAW

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The closed-loop summary of ``ctx.point`` (see :func:`closed_loop_summary`)."""
        point = ctx.point
        gains = point.gains
        theorem1 = ctx.verdicts.get("theorem1")
        paper_ok = theorem1 is None or theorem1.ok
        if gains is None or gains.integral or not (point.config.robust or paper_ok):
            return Verdict(self.name, True, False)
        loop = closed_loop_summary(point)
        c, s = loop.certificate, loop.shaped
        peaks = [] if c is None else [c.thrust.as_tuple()]
        if c is not None and s is not None and s.covered and s.thrust is not None:
            peaks.append(s.thrust.as_tuple())
        binding = None if c is None else f"operating envelope (smallest margin {c.region.margins.min:.3g})"
        bound, reference = loop.start_bound()
        return Verdict(
            self.name,
            loop.ok,
            True,
            loop.reasons,
            loop.to_dict(),
            tuple(peaks),
            binding,
            loop,
            position_bound=bound,
            bound_reference=reference,
        )

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """Decay, region, thrust and start of the closed loop (4-6 digits, with units)."""
        gains = record.get("gains")
        if figures is None:
            if gains is not None and gains.get("ki", 0.0) > 0.0:
                return [
                    "  closed loop (paper's law) not applicable: integral action is certified by the robust certificate"
                ]
            return ["  closed loop               not certified"]
        f = figures
        head = []
        fit = f.get("reference_fit")
        if fit is not None:
            inside = fit["inside"]
            head = [
                f"  reference in envelope     {sum(inside)} of {len(inside)} vehicles ({fit['frame']} frame)"
                + ("" if all(inside) else f": {fit.get('reason', '')}")
            ]
        if f["decay_rate"] is None:
            return [*head, "  closed loop               not certified"]
        r, t = f["region"], f.get("thrust")
        force = (
            f"|tau_x| <= {upper(t['force_x'], 5)} N, |tau_y| <= {upper(t['force_y'], 5)} N, "
            f"|tau_psi| <= {upper(t['moment'], 5)} N m"
            if t is not None  # records of format versions 1-3 hold the largest force and moment only
            else f"|tau_x|, |tau_y| <= {upper(f['max_force'], 5)} N, |tau_psi| <= {upper(f['max_moment'], 5)} N m"
        )
        out = [
            *head,
            f"  closed-loop decay rate    {f['decay_rate']:.4g} 1/s "
            f"(position {f['position_decay_rate']:.4g}, heading {f['heading_decay_rate']:.4g})",
            f"  start region (all at once) |e| <= {r['position_error']:.4g} m, |e'| <= {r['velocity_error']:.4g} m/s, "
            f"|e_psi| <= {r['heading_error']:.4g} rad, |e_r| <= {r['yaw_rate_error']:.4g} rad/s",
            f"  thrust over the region    {force}",
        ]
        s = f.get("shaped_start")
        if s is not None:
            how = (
                f"blend {s['blend_time']:g} s, turn {s['turn_time']:g} s"
                if s["blend_time"] is not None
                else "no blend needed"
            )
            label = f"{f.get('start_mode', 'shaped')} start"  # a saved certificate without it judged the shaped start
            out.append(f"  {label:<26}{'covered' if s['covered'] else 'NOT covered'} ({how})")
        return out

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Does the nominal certificate cover this run: its start, the nominal plant, still water?

        It chooses the run's reference: the shaped start the coverage search found, or the raw mission.
        """
        point = ctx.point
        cfg = point.config
        gains = point.require_gains()
        notes: list[str] = []
        cert: ClosedLoopCertificate | None = None
        cov: Coverage | None = None
        refuses = None
        try:
            if gains.integral:
                notes.append("integral action: the robust certificate decides (the nominal one is for the paper's law)")
            else:
                cert = closed_loop_for(point)
                cov = coverage_for(point, cert, ctx.initial, cast(StartMode, ctx.start))
                if not cov.covered:
                    notes.append(cov.reason)
        except AuvHinfError as exc:
            notes.append(f"design not certified: {exc}")
            refuses = f"design not certified: {exc}"
        if cert is None and not gains.integral and refuses is None:
            refuses = "no closed-loop certificate"
        plant = cfg.simulation.plant_params(cfg.vehicle)
        if plant != cfg.vehicle:
            notes.append("the plant differs from the controller's model; the nominal certificate assumes it is known")
        if any(c != 0.0 for c in cfg.simulation.current):
            notes.append("a current is present; the nominal certificate assumes none")
        covers = cov is not None and cov.covered and not notes
        return RunCheck(
            self.name,
            "certificate",
            not gains.integral,
            covers,
            "" if cov is None else cov.reason,
            tuple(notes),
            # the run's own bounds, about its reference: what the separation condition holds the pairs to
            bounds=cov.bounds.to_dict() if covers and cov is not None else None,
            thrust=None if cov is None else cov.thrust,
            reference=None if cov is None else cov.reference,
            refuses_gains=refuses,
            detail=(cert, cov),
        )


__all__ = [
    "FULL_CIRCLE_RTOL",
    "ClosedLoopSummary",
    "closed_loop_for",
    "closed_loop_summary",
    "coverage_for",
    "full_heading_range",
    "mission_checks",
]
