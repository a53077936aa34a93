"""The robust part: the design's gains on every plant of the declared box, in the declared current.

:func:`robust_summary` certifies the design's gains (the robust design's when ``[design]
robust = true``, else Theorem 1's) for the declared ``[uncertainty]`` box and
``[disturbance]`` current along the mission, with margins and the weakest corner;
:func:`check_robust_run` says whether one simulated run (plant, current, start) is covered
and gives its certified bounds. :class:`RobustPart` is the part of the certificate.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import Actuators, floor_peak
from auv_hinf.actuation.thrust import ThrustBounds
from auv_hinf.certificate.answers import advice
from auv_hinf.certificate.design_point import DesignPoint, design_point, initial_states
from auv_hinf.certificate.part import (
    FORMATION_LAW,
    RUN_RTOL,
    ControlLaw,
    PartContext,
    RunCheck,
    RunContext,
    Verdict,
)
from auv_hinf.certificate.parts.closed_loop import closed_loop_for, closed_loop_summary, mission_checks
from auv_hinf.certificate.reason import Reason, Setting, apart, reason_from, toml_line, upper
from auv_hinf.closed_loop.coverage import initial_errors
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.config.settings import FormationConfig, with_settings
from auv_hinf.exceptions import AuvHinfError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import FleetReference, ReferenceTube
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.mission.separation import slot_separation
from auv_hinf.mission.tubes import fleet_tube
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR
from auv_hinf.robust.bandwidth import RobustDesign
from auv_hinf.robust.box import PARAMETERS, ParameterBox, TubeSummary
from auv_hinf.robust.invariant_set import OPERATING_WIDEN, RobustCertificate, robust_certificate
from auv_hinf.robust.margin import RobustMargin, Witness, largest_certifiable, robust_margin, weakest_corner

#: The part's registry name and JSON key.
PART = "robust"
#: Largest fleet whose own shaped tube is built to check a run (the tube costs ~0.1-1 s a vehicle).
RUN_TUBE_MAX_N = 16


@dataclass(frozen=True)
class RobustSummary:
    """What ``certify`` reports under ``robust``.

    Attributes
    ----------
    declared : bool
        A box or a current is declared (otherwise everything reduces to the nominal loop).
    certificate : RobustCertificate or None
    margin : RobustMargin or None
    worst : Witness or None
        The corner plant and current with the least linearised stability margin.
    design : RobustDesign or None
        Present when ``[design] robust = true``.
    nominal_rate : float or None
        The nominal closed-loop decay rate (1/s), reported when nothing is declared.
    reasons : tuple of Reason
        Why the declared box and current are not covered, beyond the certificate's own reasons.
    gains : Gains or None
        The gains certified (those of the design point).
    without_integral : RobustCertificate or None
        With integral action: the same gains with ``ki = 0``, for comparison.
    """

    declared: bool
    certificate: RobustCertificate | None
    margin: RobustMargin | None
    worst: Witness | None
    design: RobustDesign | None
    nominal_rate: float | None
    reasons: tuple[Reason, ...]
    gains: Gains | None = None
    without_integral: RobustCertificate | None = None

    @property
    def covers(self) -> bool:
        """The robust certificate covers the declared box and current (the nominal loop when none)."""
        if not self.declared:
            return self.nominal_rate is not None and not self.reasons
        return self.certificate is not None and self.certificate.covers and not self.reasons

    def integral(self) -> dict[str, Any] | None:
        """The ``integral`` object of ``robust``: the position bound with and without integral action (m).

        ``None`` without integral action. ``position_bound_without`` is the certified bound of the
        same ``alpha``, ``k1`` and heading gains with ``ki = 0`` (``None`` when that does not cover),
        ``integral_bound`` the bound of the integrator state ``|z|`` (m s).
        """
        c = self.certificate
        if c is None or not c.gains.integral:
            return None
        w = self.without_integral
        return {
            "ki": c.gains.ki,
            "position_bound": None if c.bounds is None else c.bounds.position,
            "integral_bound": c.integral_bound,
            "position_bound_without": None if w is None or not w.covers or w.bounds is None else w.bounds.position,
            "covers_without": bool(w is not None and w.covers),
        }

    def to_dict(self) -> dict[str, Any]:
        """The ``robust`` object of ``auv-hinf certify --json``."""
        c = self.certificate
        b = None if c is None else c.bounds
        if not self.declared and self.nominal_rate is not None:
            b = ErrorBounds(0.0, 0.0, 0.0, 0.0)  # a perfectly known plant without current: errors -> 0
        rate = self.nominal_rate if not self.declared else (None if c is None else c.decay_rate)
        gains = self.gains if c is None else c.gains
        return {
            "declared": self.declared,
            "stable": bool(c is not None and c.stable) or (not self.declared and self.nominal_rate is not None),
            "covers": self.covers,
            "decay_rate": rate,
            "ultimate_bounds": None
            if b is None
            else {"position": b.position, "velocity": b.velocity, "heading": b.heading, "yaw_rate": b.yaw_rate},
            "margin": None if self.margin is None else self.margin.to_dict(),
            "worst_vertex": None if self.worst is None else self.worst.to_dict(),
            "gains": None if gains is None else gains.to_dict(),
            "design": None if self.design is None else self.design.to_dict(),
            "details": None if c is None else c.to_dict(),
            "reasons": [r.message for r in self.reasons] + ([] if c is None else list(c.reasons)),
            "box_declared": bool(c is not None and c.box.declared),
            "current_speed": None if c is None else c.current,
            "thrust": None if c is None or c.thrust is None else c.thrust.to_dict(),
        } | ({} if (integral := self.integral()) is None else {"integral": integral})


def robust_summary(
    point: DesignPoint, *, margins: bool = True, nominal: ClosedLoopCertificate | None = None
) -> RobustSummary:
    """Certify the design's gains for its declared box and current (see the module docstring).

    ``nominal`` is the nominal closed-loop certificate of the design's gains along the
    mission (:func:`~auv_hinf.certificate.parts.closed_loop.closed_loop_for`) when the caller has it
    already; otherwise it is computed here. It supplies the envelope and heading-range checks
    and, with nothing declared, the whole summary: its decay rate, errors converging to zero,
    no margins.

    Parameters
    ----------
    point : DesignPoint
        The design point (box, current, gains, tube, robust design).
    margins : bool
        Also compute the robust margins (how far the box and current can grow), when the
        certificate is stable.
    nominal : ClosedLoopCertificate, optional
        The nominal closed-loop certificate, when the caller has it.
    """
    cfg = point.config
    box, current, declared = point.box, point.current, point.declared
    design = point.robust_design
    tube, speed = point.tube, TubeSummary.of(point.tube).speed[1]
    try:
        gains = mission_checks(point)
        if nominal is None and not gains.integral:  # integral action: the robust certificate alone
            nominal = closed_loop_for(point)
    except AuvHinfError as exc:
        return RobustSummary(declared, None, None, None, design, None, (reason_from(PART, exc, "not certified: "),))
    if not declared:  # integral action is declared: here the nominal certificate exists
        return RobustSummary(False, None, None, None, design, None if nominal is None else nominal.rate, (), gains)
    reasons: list[Reason] = []
    if cfg.disturbance.current_rate:
        reasons.append(
            Reason(
                PART,
                "unsupported",
                "a time-varying current (current_rate > 0) is not certified by the robust certificate, which assumes "
                "it constant (the composed certificate, with an [implementation] sample_time, covers a bounded rate)",
                channel="current_rate",
                value=cfg.disturbance.current_rate,
                limit=0.0,
                settings=(Setting("disturbance", "current_rate", 0.0),),
            )
        )
    cert = robust_certificate(box, cfg.envelope, tube, gains, current, cfg.force_limits)
    margin = None
    if margins and cert.stable:

        def covers(s: float) -> bool:
            b, c = box.scaled(s), current * s
            return robust_certificate(b, cfg.envelope, tube, gains, c, cfg.force_limits, until_covered=True).covers

        margin = robust_margin(box, gains, speed, current, covers)
    worst = weakest_corner(box, gains, speed, current)
    without = None
    if gains.integral:
        without = robust_certificate(box, cfg.envelope, tube, replace(gains, ki=0.0), current, cfg.force_limits)
    return RobustSummary(True, cert, margin, worst, design, None, tuple(reasons), gains, without)


@dataclass(frozen=True)
class RobustRunCheck:
    """The robust certificate's verdict on one run.

    Attributes
    ----------
    covered : bool
    bounds : dict or None
        Certified per-vehicle error bounds for this run (m, m/s, rad, rad/s).
    reason : str
    design_covered : bool or None
        The robust certificate of the gains covers the declared box and current along the
        mission, whatever this run's plant and start (``None`` when not evaluated).
    thrust : ThrustBounds or None
        The certificate's bound of the commanded force when it covers the run (N, N, N m).
    """

    covered: bool
    bounds: dict[str, float] | None
    reason: str
    design_covered: bool | None = None
    thrust: ThrustBounds | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {"covered": self.covered, "bounds": self.bounds, "reason": self.reason}


def _within(x: float, lo: float, hi: float) -> bool:
    """``x`` lies in ``[lo, hi]`` widened by :data:`~auv_hinf.certificate.part.RUN_RTOL`.

    A multiplier in its range, or a speed below its bound.
    """
    return lo * (1 - RUN_RTOL) <= x <= hi * (1 + RUN_RTOL)


def plant_outside_box(cfg: FormationConfig, box: ParameterBox) -> str | None:
    """Why the simulated plant is outside the declared box, or ``None`` when it is inside.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its ``[simulation] plant`` multipliers).
    box : ParameterBox
        The declared box.
    """
    mult = dict(cfg.simulation.plant)
    outside = [
        f"{name} = {m:g} (box [{box.lo[k]:g}, {box.hi[k]:g}])"
        for k, name in enumerate(PARAMETERS)
        if not _within(m := float(mult.get(name, 1.0)), box.lo[k], box.hi[k])
    ]
    if not outside:
        return None
    each = "multiplier" if len(outside) == 1 else "multipliers"
    return f"plant {each} {', '.join(outside)} outside the declared box"


def _run_outside(point: DesignPoint) -> str | None:
    """Why the configured run's plant or current is outside what is declared (``None``: inside)."""
    why = run_outside(point)
    return None if why is None else why.message


def _current_within(current: FloatArray, bound: float) -> list[float]:
    """``current`` (m/s) scaled to the speed ``bound`` (m/s), each component rounded towards zero to 4 decimals."""
    scale = bound / float(np.hypot(*current))
    return [math.copysign(math.floor(abs(c) * scale * 1e4) / 1e4, c) + 0.0 for c in current]  # + 0.0: no -0.0


def run_outside(point: DesignPoint, part: str = PART, varying_current: bool = False) -> Reason | None:
    """Why the configured run lies outside the declared box and current (``None``: inside it).

    The reason carries the ``[simulation]`` values that bring the run inside: a multiplier outside
    the box moved to the box's nearest edge, a current above the declared bound scaled down to it
    (rounded towards zero to 4 decimals, so that the value written stays inside).

    Parameters
    ----------
    point : DesignPoint
        The design point (configured plant and current, declared box and bound).
    part : str
        The part whose certificate it is about (the reason's part).
    varying_current : bool
        The certificate covers a current that varies at the declared ``current_rate`` (the composed
        one does, the robust one does not).
    """
    cfg = point.config
    words = []
    plant = plant_outside_box(cfg, point.box)
    if plant is not None:
        words.append(f"{plant}: move [simulation.plant] into the box, or widen the [uncertainty] box")
    speed = float(np.hypot(*cfg.simulation.current))
    fast = not _within(speed, 0.0, point.current)
    if fast:
        run, bound = apart(speed, point.current)
        need = run if float(run) >= speed else repr(speed)  # a bound written as printed covers the run
        words.append(
            f"current {run} m/s exceeds the declared bound {bound} m/s: lower [simulation] current to the bound, "
            f"or declare [disturbance] current_speed >= {need} m/s (the certificate is then computed for it)"
        )
    if words:  # one reason with every value that brings the run inside: one re-run certifies
        return Reason(
            part,
            "not_covered",
            "the configured run's " + "; and its ".join(words),
            channel="current" if fast and plant is None else None,
            value=speed if fast and plant is None else None,
            limit=point.current if fast and plant is None else None,
            settings=run_settings(cfg, ()),
        )
    if cfg.disturbance.current_rate and not varying_current:
        return Reason(part, "not_covered", "a time-varying current is not certified")
    return None


def run_kept_inside(cfg: FormationConfig, reason: Reason) -> Reason:
    """``reason`` with the ``[simulation]`` values that keep the configured run inside what its settings declare.

    Advice (a reason with settings) that lowers ``[disturbance] current_speed`` below the configured
    run's current, or moves an ``[uncertainty]`` range past the run's ``[simulation.plant]``
    multiplier, or leaves a run that is already outside the declared system there, would be refused
    when re-run for that run, which no bound covers (the separation part): the run's current is scaled
    to the bound and the multiplier moved into the range. A reason without settings is returned as it is.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration the advice is about.
    reason : Reason
        A reason, with or without settings.
    """
    extra = run_settings(cfg, reason.settings) if reason.settings else ()
    if not extra:
        return reason
    words = f" (with {', '.join(x.words() for x in extra)}, which keeps the configured run inside)"
    tail = " (re-run with it)"
    head = reason.message.removesuffix(tail)
    message = head + words + (tail if head != reason.message else "")
    return replace(reason, message=message, settings=(*reason.settings, *extra))


def run_settings(cfg: FormationConfig, settings: Sequence[Setting]) -> tuple[Setting, ...]:
    """The ``[simulation]`` values that keep ``cfg``'s configured run inside what ``settings`` declare.

    The declared system after the advice: ``settings``' current bound and box ranges where they give
    them, ``cfg``'s elsewhere. See :func:`run_kept_inside`; empty when the run stays inside.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration the settings are advised for.
    settings : sequence of Setting
        The advised values.
    """
    named = {(x.table, x.key): x.value for x in settings}
    extra: list[Setting] = []
    bound = float(named.get(("disturbance", "current_speed"), cfg.disturbance.current_speed) or 0.0)
    cur = np.asarray(cfg.simulation.current, dtype=float)
    if ("simulation", "current") not in named and not _within(float(np.hypot(*cur)), 0.0, bound):
        extra.append(Setting("simulation", "current", _current_within(cur, bound)))
    mult, declared = dict(cfg.simulation.plant), dict(cfg.uncertainty.box)
    for name in PARAMETERS:
        # a range removed (None) or never declared: the coefficient is the model's
        rng = named[("uncertainty", name)] if ("uncertainty", name) in named else declared.get(name)
        lo, hi = rng or (1.0, 1.0)
        m = float(mult.get(name, 1.0))
        if not _within(m, lo, hi) and ("simulation.plant", name) not in named:
            extra.append(Setting("simulation.plant", name, float(np.clip(m, lo, hi))))
    return tuple(extra)


def figures_kept_inside(cfg: FormationConfig, figures: Any) -> Any:
    """``figures`` (a part's JSON object) with every advised ``settings`` list completed by :func:`run_settings`.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    figures : Any
        Nested dictionaries and lists; other values are returned as they are.
    """
    if isinstance(figures, list):
        return [figures_kept_inside(cfg, x) for x in figures]
    if not isinstance(figures, dict):
        return figures
    out = {k: figures_kept_inside(cfg, v) for k, v in figures.items()}
    listed = out.get("settings")
    if isinstance(listed, list) and listed and all(isinstance(x, dict) and {"table", "key"} <= set(x) for x in listed):
        extra = run_settings(cfg, [Setting(x["table"], x["key"], x.get("value")) for x in listed])
        out["settings"] = listed + [x.to_dict() for x in extra]
    return out


@dataclass(frozen=True)
class ConfiguredRun:
    """What the robust certificate proves for the configured run (:func:`configured_run`).

    Attributes
    ----------
    bounds : ErrorBounds
        The errors' sup over every ``t >= 0`` of the run (m, m/s, rad, rad/s).
    thrust : ThrustBounds or None
        The commanded force's bound along the run (N, N, N m).
    held_by : str
        The certificate whose start set holds the run's start (:data:`HELD_BY`).
    """

    bounds: ErrorBounds
    thrust: ThrustBounds | None
    held_by: str


#: The certificates that can hold the configured run's start, in words: the operating envelope's
#: (the tightest bounds), the declared envelope's (``wider``: a larger start set, looser bounds), and
#: a shaped start's own (the mission's tube joined by the run's).
HELD_BY = {
    "operating": "the certificate's own start set",
    "declared": "the declared envelope's larger start set (looser bounds than the operating envelope's)",
    "shaped": "the certificate of the shaped start's own reference",
}


def configured_run(point: DesignPoint, rob: RobustSummary, reference: FleetReference | None) -> ConfiguredRun | None:
    """The bounds the robust certificate proves for the configured run, and which of its sets holds the start.

    They hold when the certificate covers the declared box and current, the configured plant and
    current are inside them, and the configured start lies in a certified invariant set against
    ``reference``: then the errors stay within them for every ``t >= 0`` (not only ultimately). A
    start only the declared envelope's certificate holds (:meth:`~auv_hinf.robust.invariant_set.
    RobustCertificate.covering`) has its looser bounds and thrust; a shaped ``reference`` is checked
    on its own tube (:func:`check_robust_run`). ``None`` when no set holds the run.

    Parameters
    ----------
    point : DesignPoint
        The design point (configured start, plant and current).
    rob : RobustSummary
        Its robust summary.
    reference : FleetReference or None
        The reference the run tracks (``None``: the raw mission).
    """
    c = rob.certificate
    if not rob.declared or rob.reasons or c is None or not c.covers or c.bounds is None:
        return None
    fleet = point.fleet() if reference is None else reference
    initial = initial_states(point)
    if fleet.shaping is not None:
        rc = check_robust_run(point, fleet, initial)
        if not rc.covered or rc.bounds is None:
            return None
        return ConfiguredRun(ErrorBounds(**rc.bounds), rc.thrust, "shaped")
    if _run_outside(point) is not None:
        return None
    bound = float(point.config.disturbance.current_speed or 0.0)
    if bound > 0.0 and point.config.simulation.initial is None:
        # on the slots at the mission's water speed: the start must lie in the set in every current up to the
        # bound, not only the configured one (a declared start is judged in the configured current it was set for)
        for cert, limit in set_current_limits(point, rob):
            if limit >= bound and cert.bounds is not None:
                return ConfiguredRun(_floored(cert.bounds), cert.thrust, "operating" if cert is c else "declared")
        return None
    cur = np.asarray(point.config.simulation.current, dtype=float)
    e, de, epsi, depsi = initial_errors(fleet, initial, cur)
    covering = c.covering(e, de, epsi, depsi, cur)
    if covering is None or covering.bounds is None:
        return None
    return ConfiguredRun(_floored(covering.bounds), covering.thrust, "operating" if covering is c else "declared")


def _floored(bounds: ErrorBounds) -> ErrorBounds:
    """``bounds`` raised to the integrator's floor, as a simulated run is judged against them (a plant known
    exactly certifies a heading error of 0, which a run meets to about 1e-9)."""
    return ErrorBounds(*(max(float(v), NUMERICAL_FLOOR) for v in bounds.to_dict().values()))


#: Re-runs tried by :func:`current_start_refusal`: the largest current in which the configured start lies in
#: a certified set is re-run; a robust design chooses its gains again for it, and their start set may hold
#: the start only in a smaller current still, which is tried next (at most half the last).
START_CURRENT_RERUNS = 2


def current_start_refusal(point: DesignPoint, rob: RobustSummary) -> Reason | None:
    """The refusal of a start on the slots that no certified set holds in every current up to the declared bound.

    Without ``[simulation] initial`` the vehicles start on their slots at the mission's velocity through
    the water, so a current is a ground-velocity error at ``t = 0``: a run from that start in a current
    the declaration allows, but the set does not hold, is not covered (the composed and the guidance
    certificates judge the start the same way). ``None`` when a start is declared (judged in the
    configured current it was set for) or the start is held. The answer
    is the largest current in which the start lies in a set (:func:`start_current_limit`), rounded down,
    each confirmed by designing and certifying the rewritten configuration as a re-run does; when the
    re-run's gains hold the start in a smaller current still, that one is tried next
    (:data:`START_CURRENT_RERUNS`).

    Parameters
    ----------
    point : DesignPoint
        The design point (configured start, current bound).
    rob : RobustSummary
        Its robust summary (the certificate covers the declared box and current).
    """
    cfg = point.config
    bound = float(cfg.disturbance.current_speed or 0.0)
    if bound <= 0.0 or cfg.simulation.initial is not None or _run_outside(point) is not None:
        return None
    if configured_run(point, rob, None) is not None:
        return None
    limit = start_current_limit(point, rob)
    written = significant(float(limit or 0.0), ADVISED_DIGITS, up=False)
    why = (
        f"the configured start lies in the certified start set only in currents up to "
        f"{written:g} m/s, not in every current up to the declared "
        f"{bound:g} m/s: the vehicles start at their speed through the water, so a current is a velocity error at "
        "t = 0, and a run from this start in a stronger current is not covered"
    )
    got = start_confirmed(cfg, (Setting("disturbance", "current_speed", written),)) if written > 0.0 else None
    settings = got or ()
    if settings:
        why += f"; it certifies with {toml_line(settings)} (re-run with it)"
    elif limit:
        why += (
            "; no smaller declared current tried certifies it (the design's start set shrinks with the current): "
            "a fleet that starts at its ground velocity in the current, or a start declared for the configured "
            "current ([simulation] initial), is judged instead"
        )
    return Reason(PART, "start", why, channel="current_speed", value=bound, limit=limit, settings=settings)


def start_confirmed(cfg: FormationConfig, settings: tuple[Setting, ...]) -> tuple[Setting, ...] | None:
    """``settings``, their ``[disturbance] current_speed`` lowered where needed, so that a re-run holds the start.

    A re-run designs its gains again (a robust design), and their start set may hold the configured
    start only in a smaller current than the one written: the re-run's own limit
    (:func:`start_current_limit`) is then written, rounded down, at most half the last
    (:data:`START_CURRENT_RERUNS` times). ``None`` when none holds; ``settings`` as given when a current
    is not declared in the re-run (nothing to hold the start against) or the first re-run holds.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    settings : tuple of Setting
        An answer to re-run with.
    """
    key = ("disturbance", "current_speed")
    trial = settings
    for attempt in range(START_CURRENT_RERUNS + 1):
        holds, again = _start_holds(cfg, trial)
        if holds:
            return trial
        if again is None or attempt == START_CURRENT_RERUNS:
            return None
        last = next(
            (float(x.value) for x in trial if (x.table, x.key) == key), float(cfg.disturbance.current_speed or 0.0)
        )
        value = significant(min(again, 0.5 * last) if attempt else again, ADVISED_DIGITS, up=False)
        if not value > 0.0:
            return None
        trial = (*(x for x in trial if (x.table, x.key) != key), Setting(*key, value))
    return None


def _start_holds(cfg: FormationConfig, settings: tuple[Setting, ...]) -> tuple[bool, float | None]:
    """Whether a re-run of ``cfg`` with ``settings`` holds: designed, covering its box and current, the configured
    start in its set in every current up to the bound, ``[formation] min_separation`` kept; and the re-run's own
    :func:`start_current_limit` (``None``: none)."""
    written = (*settings, *run_settings(cfg, settings))  # the configured run kept inside, as the answer says
    try:
        point = design_point(with_settings(cfg, [(s.table, s.key, s.value) for s in written]))
        rob = robust_summary(point, margins=False)
    except AuvHinfError:
        return False, None
    if not rob.covers or point.reasons:
        return False, None
    reference = None  # a declared start judged shaped: the reference the closed loop's coverage search chose
    if point.config.simulation.start == "shaped" and point.config.simulation.initial is not None:
        try:
            reference = closed_loop_summary(point).start_bound()[1]
        except AuvHinfError:
            return False, None
    run = configured_run(point, rob, reference)
    # the separation part's test (:attr:`SeparationBound.ok <auv_hinf.certificate.parts.separation.SeparationBound.ok>`)
    holds = run is not None and slot_separation(point.fleet()).keeps(run.bounds.position, point.config.min_separation)
    return holds, start_current_limit(point, rob)


def start_current_limit(point: DesignPoint, rob: RobustSummary) -> float | None:
    """The largest current (m/s, in any direction) in which the configured start lies in a certified start set.

    The larger of the two sets' limits (:func:`set_current_limits`), at most the declared
    ``[disturbance] current_speed``; ``None`` when the certificate does not cover or the start is
    outside its sets even in still water.

    Parameters
    ----------
    point : DesignPoint
        The design point (configured start and declared current).
    rob : RobustSummary
        Its robust summary.
    """
    limits = [limit for _, limit in set_current_limits(point, rob)]
    return max(limits) if limits else None


def set_current_limits(point: DesignPoint, rob: RobustSummary) -> list[tuple[RobustCertificate, float]]:
    """Each covering set's largest current (m/s, in any direction) in which the configured start lies in it.

    The configured vehicles' velocities through the water are fixed, so in a current ``c`` their
    ground-velocity errors are those of still water plus ``c``, and the equilibrium the position set
    is about moves linearly with ``c``: each vehicle's level in the position set is a convex
    quadratic ``q(c) = c^T A c + 2 b.c + g``, its coefficients read exactly from its values at
    ``c = 0``, ``+-h e_x``, ``+-h e_y`` and ``h (e_x + e_y)``. Over ``|c| <= C``, ``q <= lambda_max(A)
    C^2 + 2 |b| C + g``, so the start lies in the set in every current up to the root of that bound
    at the set's level (the heading set does not depend on the current). The certificate's own set
    and the declared envelope's (:meth:`~auv_hinf.robust.invariant_set.RobustCertificate.covering`)
    are judged, each limit at most the declared ``[disturbance] current_speed``; a set that does not
    hold the start even in still water is left out, and so is every set of a shaped start (its
    reference starts from the vehicles' own ground velocity) or of a certificate that does not cover.

    Parameters
    ----------
    point : DesignPoint
        The design point (configured start and declared current).
    rob : RobustSummary
        Its robust summary.
    """
    c = rob.certificate
    bound = float(point.config.disturbance.current_speed or 0.0)
    if c is None or not c.covers or rob.reasons or bound <= 0.0:
        return []
    fleet, initial = point.fleet(), initial_states(point)
    if fleet.shaping is not None:
        return []
    step = bound  # m/s: the levels are read at the size of the currents they are judged in
    probes = [(0.0, 0.0), (step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step), (step, step)]
    out: list[tuple[RobustCertificate, float]] = []
    for cert in (c, c.wider):
        if cert is None or not cert.covers:
            continue
        levels = []
        for x in probes:
            e, de, epsi, depsi = initial_errors(fleet, initial, np.array(x))
            got = cert.start_levels(e, de, epsi, depsi, np.array(x))
            if got is not None:
                levels.append(got)
        if len(levels) < len(probes):
            continue
        q0, vh, (top_p, top_h) = levels[0]
        qx, qmx, qy, qmy, qxy = (lv[0] for lv in levels[1:])
        if np.any(q0 > top_p) or np.any(vh > top_h):
            continue
        axx, ayy = (qx + qmx - 2.0 * q0) / (2.0 * step**2), (qy + qmy - 2.0 * q0) / (2.0 * step**2)
        axy = (qxy - q0 - step * ((qx - qmx) + (qy - qmy)) / (2.0 * step) - step**2 * (axx + ayy)) / (2.0 * step**2)
        b = np.hypot((qx - qmx) / (4.0 * step), (qy - qmy) / (4.0 * step))
        lam = np.maximum(0.5 * (axx + ayy) + np.hypot(0.5 * (axx - ayy), axy), 0.0)
        room = np.maximum(top_p - q0, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.where(lam > 0.0, (np.sqrt(b * b + lam * room) - b) / lam, room / np.maximum(2.0 * b, 1e-300))
        out.append((cert, min(bound, float(np.min(root)) * (1.0 - START_LIMIT_RTOL))))
    return out


#: Relative margin taken off :func:`start_current_limit`'s root: the quadratic's coefficients are read
#: from six levels evaluated at currents of the declared size, each with a round-off of about 1e-15 of
#: the largest level (at most about 100 times the set's); 1e-6 leaves a millionfold room for it.
START_LIMIT_RTOL = 1e-6


def check_robust_run(point: DesignPoint, fleet: FleetReference, initial: FloatArray) -> RobustRunCheck:
    """Whether the robust certificate covers the run of the design's configuration tracking ``fleet`` from ``initial``.

    Covered when the plant is in the declared box, the current within the declared bound, the
    certificate (on the mission tube and, for a shaped start, the run's own tube) covers, and
    every vehicle starts inside both certified ellipsoids.

    Parameters
    ----------
    point : DesignPoint
        The design point (configured plant, current, box, gains, tube).
    fleet : FleetReference
        The reference the run tracks (raw mission or shaped start).
    initial : ndarray, shape (N, 6)
        Initial states ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    """
    cfg = point.config
    box, bound = point.box, point.current
    cur = np.asarray(cfg.simulation.current, dtype=float)
    why = _run_outside(point)
    if why is not None:
        return RobustRunCheck(False, None, why)
    try:
        tube = point.tube
        gains = point.require_gains()
        if fleet.shaping is not None:
            if cfg.n > RUN_TUBE_MAX_N:
                return RobustRunCheck(
                    False, None, f"not evaluated: shaped start of more than {RUN_TUBE_MAX_N} vehicles"
                )
            tube = ReferenceTube.concatenate([tube, fleet_tube(fleet)])
        cert = robust_certificate(box, cfg.envelope, tube, gains, bound, cfg.force_limits)
    except AuvHinfError as exc:
        return RobustRunCheck(False, None, f"not certified: {exc}")
    if not cert.covers or cert.bounds is None:
        why = "; ".join(cert.reasons) or "the robust certificate does not cover"
        return RobustRunCheck(False, None, why, design_covered=False if fleet.shaping is None else None)
    e, de, epsi, depsi = initial_errors(fleet, initial, (float(cur[0]), float(cur[1])))
    covering = cert.covering(e, de, epsi, depsi, cur)
    b = (cert if covering is None else covering).bounds
    assert b is not None  # a covering certificate has bounds
    # raised to the integrator's floor: the simulated run obeys them to its accuracy
    bounds = {k: max(v, NUMERICAL_FLOOR) for k, v in b.to_dict().items()}
    if covering is None:
        return RobustRunCheck(False, bounds, "the start is outside the certified invariant set", design_covered=True)
    why = "covered: plant and current declared, start inside the certified set"
    return RobustRunCheck(True, bounds, why, design_covered=True, thrust=covering.thrust)


def design_answer(point: DesignPoint, act: Actuators | None) -> dict[str, Any]:
    """The box scale and current that certify ``point``'s design within ``act`` (:func:`largest_certifiable`).

    The design's box, envelope, tube, gains and current, each answer confirmed by re-running its
    robust design (``[design] synthesis`` and ``integral``) when the gains are the robust design's.

    Parameters
    ----------
    point : DesignPoint
        The design point (its gains are set).
    act : Actuators or None
        The force limits (N, N, N m); ``None``: none declared.
    """
    cfg, gains = point.config, point.require_gains()
    redesign = cfg.synthesis if cfg.robust else None
    return largest_certifiable(
        point.box, cfg.envelope, point.tube, gains, point.current, act, redesign=redesign, integral=cfg.integral
    )


def _actuators_answer(cfg: FormationConfig, cert: RobustCertificate) -> bool:
    """The actuators part answers ``cert``'s refusal: limits are declared and its force bound does not fit them."""
    act = cfg.force_limits
    return act is not None and (cert.thrust is None or not act.admits(floor_peak(cert.thrust.as_tuple())))


@dataclass(frozen=True)
class RobustPart:
    """Every plant of the declared box, every current up to the declared bound (see the module docstring).

    With nothing declared it reports the nominal loop's decay rate and holds; it applies when a
    box, a current or integral action is declared, or when the robust design gives the gains.
    """

    name: str = PART
    key: str | None = PART
    #: The fully actuated formation law only (with ``[guidance]`` the assembly does not evaluate it).
    laws: tuple[ControlLaw, ...] = FORMATION_LAW

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The robust summary of ``ctx.point``, reusing the closed-loop part's certificate."""
        point = ctx.point
        design_failed = [r for r in point.reasons if r.part == self.name]
        loop = ctx.detail("closed_loop")
        rob = robust_summary(point, nominal=None if loop is None else loop.certificate)
        c = rob.certificate
        peaks = () if not rob.declared or c is None or c.thrust is None else (c.thrust.as_tuple(),)
        margins = None if not rob.declared or c is None else c.margins
        binding = None if margins is None else f"operating envelope (smallest margin {margins.min:.3g})"
        figures = rob.to_dict()
        figures["start_current_limit"] = start_current_limit(point, rob) if rob.declared else None
        applies = rob.declared or point.source == "robust"
        if design_failed:  # the robust design gave no gains: that is the verdict
            return Verdict(self.name, False, True, tuple(design_failed), figures, peaks, binding, rob)
        if rob.declared and not rob.covers:
            cfg = point.config
            declared = " and ".join(
                what
                for what, there in (
                    ("[uncertainty] box", cfg.uncertainty.box),
                    ("[disturbance] current", cfg.disturbance.current_speed),
                )
                if there
            )
            hint = (
                "; the gains are the nominal Theorem 1 design: [design] robust = true designs them for the box "
                "and the current"
                if not cfg.robust
                else ""
            )
            settings: tuple[Setting, ...] = ()
            if not rob.reasons and c is not None and point.gains is not None and not _actuators_answer(cfg, c):
                # the actuators part answers a refusal whose force does not fit; otherwise this part does
                best = design_answer(point, cfg.force_limits)
                figures["largest_certifiable"] = best
                # confirmed with the configured start, held in every current up to the one written
                found = advice(best)
                settings = (start_confirmed(cfg, found) or ()) if found else ()
            answer = f"; it certifies with {toml_line(settings)} (re-run with these)" if settings else ""
            why = Reason(
                self.name,
                "not_covered",
                f"robust certificate does not cover the declared {declared or '[uncertainty] box and current'}: "
                + ("; ".join(figures["reasons"]) or "see robust")
                + hint
                + answer,
                settings=settings,
            )
            return Verdict(self.name, False, True, (why,), figures, peaks, binding, rob)
        earlier = ctx.verdicts.get("closed_loop")
        reference = None if earlier is None else earlier.bound_reference  # the start the closed loop chose
        if rob.declared:
            run = configured_run(point, rob, reference)
            bound = None if run is None else run.bounds.position
            figures["held_by"] = None if run is None else run.held_by
            shaped = reference is not None and reference.shaping is not None
            weak = None if run is not None or shaped else current_start_refusal(point, rob)
            if weak is not None:  # held in the configured current, not in every current the declaration allows
                return Verdict(self.name, False, True, (weak,), figures, peaks, binding, rob)
            if run is not None:  # the bounds the configured run obeys, floored as a run is judged
                figures["ultimate_bounds"] = run.bounds.to_dict()
            if run is not None and run.held_by != "operating":  # the configured run has the looser set's numbers
                if run.thrust is not None:
                    figures["thrust"] = run.thrust.to_dict()
                    peaks = (*peaks, run.thrust.as_tuple())
        else:  # nothing declared: the robust certificate is the nominal one, and so is its bound
            bound = None if earlier is None or not rob.covers else earlier.position_bound
        return Verdict(
            self.name,
            True,
            applies,
            (),
            figures,
            peaks,
            binding,
            rob,
            position_bound=bound,
            bound_reference=None if bound is None else reference,
        )

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The robust certificate's lines when a box or a current is declared (none otherwise)."""
        f = figures
        if f is None or not f["declared"]:
            return []
        current = f.get("current_speed")
        model_only = current is not None and not f.get("box_declared", True) and not current > 0.0
        declared = [x for x, on in (("box", f.get("box_declared", True)), ("current", bool(current))) if on]
        what = (
            "the controller's model (no box or current declared)"
            if model_only
            else f"the declared {' and '.join(declared) or 'box and current'}"
        )
        out = [f"  robust certificate        {'covers' if f['covers'] else 'does NOT cover'} {what}"]
        b = f["ultimate_bounds"]
        if b is not None and f["decay_rate"] is not None:
            out.append(
                f"    decay rate {f['decay_rate']:.4g} 1/s; ultimate |e| <= {upper(b['position'], 4)} m, "
                f"|e'| <= {upper(b['velocity'], 4)} m/s, |e_psi| <= {upper(b['heading'], 4)} rad, "
                f"|e_r| <= {upper(b['yaw_rate'], 4)} rad/s"
            )
        held = f.get("held_by")
        if held is not None and held != "operating":
            out.append(f"    these bounds and the thrust are the configured start's: it lies in {HELD_BY[held]}")
        op = (f.get("details") or {}).get("operating_envelope")
        if op is not None:
            d = f["details"]
            whose = (
                "computed over the velocities these bounds allow"
                if held in (None, "operating")
                else "the tighter certificate (whose smaller set does not hold the start) is computed over the "
                "velocities its bounds allow"
            )
            out.append(
                f"    {whose} ({100 * OPERATING_WIDEN:g} % wider): "
                f"u in [{op['u'][0]:.3g}, {op['u'][1]:.3g}] m/s, "
                f"v in [{op['v'][0]:.3g}, {op['v'][1]:.3g}] m/s, r in [{op['r'][0]:.3g}, {op['r'][1]:.3g}] rad/s "
                f"(drag spread sigma {d['sigma']:.3g} 1/s there, {d['declared_sigma']:.3g} 1/s over the declared "
                "envelope)"
            )
        t = f.get("thrust")
        if t is not None:
            out.append(
                f"    thrust |tau_x| <= {upper(t['force_x'], 5)} N, |tau_y| <= {upper(t['force_y'], 5)} N, "
                f"|tau_psi| <= {upper(t['moment'], 5)} N m"
            )
        if f["margin"] is not None and not model_only and f.get("details") is not None:
            out.append(f"    box scale certified up to {f['margin']['lower']:.4g} (1 = the declared box)")
        limit = f.get("start_current_limit")
        if limit is not None and current:
            held = (
                f"every current up to the declared {current:g} m/s"
                if limit >= current
                else f"currents up to {significant(limit, ADVISED_DIGITS, up=False):g} m/s (rounded down), not the "
                f"declared {current:g} m/s: a run from it in a stronger current is not covered"
            )
            out.append(f"    the configured start is in the certified start set in {held}")
        integral = f.get("integral")
        if integral is not None:
            without = integral["position_bound_without"]
            out.append(
                f"    integral action ki {integral['ki']:.4g} 1/s^3: |e| <= {upper(integral['position_bound'], 4)} m; "
                "the same alpha, k1 without it: "
                + (f"|e| <= {upper(without, 4)} m" if without is not None else "not certified")
            )
        return out

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Does the robust certificate cover this run (plant in the box, current within the bound, start inside)?"""
        point = ctx.point
        if not point.declared:
            return None
        rc = check_robust_run(point, ctx.reference, ctx.initial)
        refuses = None
        if rc.design_covered is False:
            refuses = f"the robust certificate does not cover the declared box and current: {rc.reason}"
        return RunCheck(
            self.name,
            "certificate",
            True,
            rc.covered,
            rc.reason,
            bounds=rc.bounds,
            thrust=rc.thrust,
            refuses_gains=refuses,
            detail=rc,
        )


__all__ = [
    "HELD_BY",
    "RUN_TUBE_MAX_N",
    "START_CURRENT_RERUNS",
    "ConfiguredRun",
    "RobustRunCheck",
    "RobustSummary",
    "check_robust_run",
    "configured_run",
    "current_start_refusal",
    "design_answer",
    "figures_kept_inside",
    "plant_outside_box",
    "robust_summary",
    "run_kept_inside",
    "run_outside",
    "run_settings",
    "set_current_limits",
    "start_confirmed",
    "start_current_limit",
]
