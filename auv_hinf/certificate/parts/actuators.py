"""The actuator part: the force the law commands against what the vehicles can push.

The certified peak is the elementwise largest of the thrust bounds the certificate proves
(:func:`~auv_hinf.actuation.thrust.thrust_bounds`: feed-forward, model
cancellation, current compensation and feedback, over the certified set and the whole
mission): the nominal closed loop over its start region, the configured shaped start when it
is checked, and the robust certificate of the declared box and current. The design is
certified for the actuators only when the box of these peaks fits the declared limits.

When it does not, :func:`largest_certifiable` answers what does fit, each by bisection on
certificates (the lower end of every bisection is a certified value, so re-running at it
certifies; with ``[design] robust = true`` the answer is confirmed by re-running the robust
design there, as a re-run of ``certify`` would):

* ``box_scale_alone``: the largest scale of the declared ``[uncertainty]`` box (declared current);
* ``current_speed_alone``: the largest current speed (declared box);
* ``box_scale`` and ``current_speed``: a pair that certifies *together*, the one to re-run with
  (one of the answers alone with the other declared value, both when they are confirmed
  together, else box and current scaled together), with the scaled ``uncertainty`` table.

The nominal start region needs no answer of its own: it is already shrunk to fit the limits
(:func:`~auv_hinf.closed_loop.actuator_fit.within_actuators`).

``required_limits`` (the certified peak itself) are the smallest per-channel limits that would
certify the declared case.

On an underactuated vehicle (:class:`~auv_hinf.actuation.limits.RudderActuation`: a propeller and
a rudder) the part refuses the fully actuated law outright: the law commands sway force and yaw
moment independently, and the rudder gives them only together, on one line through the origin, so
no box of the law's commands with a nonzero sway width is deliverable, whatever the gains. The
figures then say what the law would need against what the rudder gives at the envelope's top speed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from auv_hinf.actuation.limits import CHANNELS, Actuation, RudderActuation, actuator_shortfall, floor_peak
from auv_hinf.certificate.answers import advice
from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.certificate.part import PartContext, Peak, RunCheck, RunContext, Verdict
from auv_hinf.certificate.parts.robust import design_answer, start_confirmed
from auv_hinf.certificate.reason import Reason, toml_line, upper

#: The part's registry name and JSON key.
PART = "actuators"
#: An actuator channel counts as the binding constraint when the certified peak reaches this
#: share of its limit (the region is shrunk to fit the limits, so a binding channel sits at 1).
ACTUATOR_BINDING_RATIO = 0.99


@dataclass(frozen=True)
class ActuatorCheck:
    """What ``certify`` reports under ``actuators``.

    Attributes
    ----------
    limits : Actuators, RudderActuation or None
        The declared actuation (``None``: none declared, the certificate assumes unlimited thrust).
    certified_peak : tuple of float or None
        ``(|tau_x|, |tau_y|, |tau_psi|)`` the law can command on the certified set (N, N, N m);
        ``None`` when no certificate bounds it.
    binding : str or None
        What binds: the channel with the largest peak-to-limit ratio (``force_x``, ``force_y``,
        ``moment``), or ``thrusters`` when the thruster polytope binds harder.
    binding_ratio : float or None
        That ratio (above 1: the channel cannot deliver the peak).
    certified : bool
        Limits declared, a peak certified, and the peak within the limits.
    reason : str
        One sentence on the verdict.
    largest_certifiable : dict or None
        When the limits bind: a ``box_scale`` and ``current_speed`` that certify together within
        them, with the scaled ``uncertainty`` table, and each answer alone (see
        :func:`largest_certifiable`); ``None`` otherwise (JSON ``null``, the key always present).
    rudder_authority : dict or None
        For a rudder: the largest side force (N; the fin's lift, not a sway actuator: it comes only
        with its yaw moment) and yaw moment (N m) it gives at the envelope's top surge speed (m/s),
        ``{speed, side_force, moment}``, and its lever arm (m).
    guided_peak : dict or None
        With ``[guidance]``: the guidance certificate's thrust and rudder ``{force_x, rudder}`` (N, rad).
    """

    limits: Actuation | None
    certified_peak: Peak | None
    binding: str | None
    binding_ratio: float | None
    certified: bool
    reason: str
    largest_certifiable: dict[str, Any] | None = None
    rudder_authority: dict[str, float] | None = None
    guided_peak: dict[str, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The ``actuators`` object of ``auv-hinf certify --json``."""
        peak: dict[str, Any] | None = None if self.certified_peak is None else dict(zip(CHANNELS, self.certified_peak))
        if self.guided_peak is not None:
            peak = dict(self.guided_peak)  # the guidance cascade's thrust (N) and rudder (rad)
        elif peak is None and isinstance(self.limits, RudderActuation):
            peak = {"force_x": None, "rudder": None}  # nothing is certified for the propeller or the rudder
        elif peak is not None and isinstance(self.limits, RudderActuation):
            peak["rudder"] = None  # the fully actuated law has no rudder command: nothing is certified for it
        out: dict[str, Any] = {
            "kind": None if self.limits is None else self.limits.kind,
            "limits": None if self.limits is None else self.limits.to_dict(),
            "certified_peak": peak,
            "required_limits": None if self.certified_peak is None else dict(zip(CHANNELS, self.certified_peak)),
            "binding": self.binding,
            "binding_ratio": self.binding_ratio,
            "certified": self.certified,
            "reason": self.reason,
            # always present (null when the limits do not bind or nothing was searched), as in
            # ``guidance.largest_certifiable``: a reader can test the value, not the key
            "largest_certifiable": None if self.largest_certifiable is None else dict(self.largest_certifiable),
        }
        if self.rudder_authority is not None:
            out["rudder_authority"] = dict(self.rudder_authority)
        return out


def peak_of(bounds: list[Peak]) -> Peak | None:
    """Elementwise largest of thrust bounds (``None`` for none).

    A channel certified below :data:`~auv_hinf.numerics.integrators.FORCE_FLOOR` is reported at it.

    Parameters
    ----------
    bounds : list of Peak
        Thrust bounds ``(|tau_x|, |tau_y|, |tau_psi|)`` (N, N, N m).
    """
    if not bounds:
        return None
    floored = [floor_peak(b) for b in bounds]
    return tuple(max(b[k] for b in floored) for k in range(3))  # type: ignore[return-value]


#: Why no force bound reaches the actuators, by default.
UNBOUNDED = "no certificate bounds the commanded force"


def check_actuators(
    point: DesignPoint,
    peaks: list[Peak],
    *,
    answers: bool = True,
    guided: Mapping[str, float] | None = None,
    unbounded: str = UNBOUNDED,
) -> ActuatorCheck:
    """The actuator verdict of a design whose certificates bound the thrust by ``peaks``.

    Parameters
    ----------
    point : DesignPoint
        The design (its declared actuators, box and gains).
    peaks : list of Peak
        The certified thrust bounds (N, N, N m); their elementwise largest is checked.
    answers : bool
        Compute :func:`largest_certifiable` when the limits bind.
    guided : mapping or None
        With ``[guidance]``: the guidance certificate's ``{force_x, rudder}`` (N, rad), if any.
    unbounded : str
        The reason when ``peaks`` is empty.
    """
    act = point.config.actuators
    peak = peak_of(peaks)
    if act is None:
        why = "no actuator limits declared ([actuators]): the certificate assumes unlimited thrust"
        return ActuatorCheck(None, peak, None, None, False, why)
    if isinstance(act, RudderActuation):
        return rudder_check(point, act, peak, guided)
    if peak is None:
        return ActuatorCheck(act, None, None, None, False, unbounded)
    # each certificate bounds the force over the runs it covers by its own box: the boxes are checked
    # one by one (their union is deliverable when each is), not their elementwise largest, whose
    # corners mix one certificate's surge with another's sway
    boxes = [floor_peak(p) for p in peaks]
    bindings = [act.binding(p) for p in boxes]  # each one LP with thrusters: computed once
    k = max(range(len(boxes)), key=lambda i: bindings[i][1])
    worst, (channel, ratio) = boxes[k], bindings[k]
    if all(act.admits(p) for p in boxes):
        why = f"the certified peak force fits the limits (binding: {channel}, {ratio:.3g} times its limit)"
        return ActuatorCheck(act, peak, channel, ratio, True, why)
    why = actuator_shortfall(act, worst)
    if act.note:
        why += f" ({act.note})"
    best = None
    if answers and point.declared and point.gains is not None:
        best = _holding_the_start(point, design_answer(point, act))
    elif answers and point.declared:
        best = {"box_scale": None, "current_speed": None}
    return ActuatorCheck(act, peak, channel, ratio, False, why, best)


def _holding_the_start(point: DesignPoint, best: dict[str, Any]) -> dict[str, Any]:
    """``best`` with its current lowered until a re-run holds the configured start in every current up to it.

    The search answers the box and the current the certificate covers; the configured start must also lie
    in its start set in every current up to the one written (the robust part refuses otherwise,
    :func:`~auv_hinf.certificate.parts.robust.current_start_refusal`), which a re-run confirms
    (:func:`~auv_hinf.certificate.parts.robust.start_confirmed`). ``best`` is returned as it is when no
    current is declared, a start is declared (judged in the configured current it is set for), or no lower
    current holds it.
    """
    settings = advice(best)
    if not settings or not point.current or point.config.simulation.initial is not None:
        return best
    got = start_confirmed(point.config, settings)
    current = next((float(s.value) for s in got or () if s.key == "current_speed"), None)
    return best if current is None else {**best, "current_speed": current}


def guided_check(
    act: RudderActuation, guided: Mapping[str, float] | None, authority: dict[str, float]
) -> ActuatorCheck:
    """The actuator verdict of the guidance cascade: its certified thrust and rudder against the limits.

    Parameters
    ----------
    act : RudderActuation
        The propeller and rudder.
    guided : mapping or None
        The guidance certificate's ``{force_x, rudder}`` (N, rad); ``None`` when it proves none.
    authority : dict
        The rudder's authority at the envelope's top speed.
    """
    if guided is None:
        why = (
            "the guidance cascade commands the propeller and the rudder (no sway force); "
            "its certificate bounds neither (see guidance)"
        )
        return ActuatorCheck(act, None, None, None, False, why, rudder_authority=authority)
    ratios = {"force_x": guided["force_x"] / act.tau_x, "rudder": guided["rudder"] / act.rudder_max}
    channel = max(ratios, key=lambda k: ratios[k])
    ok = all(r <= 1.0 for r in ratios.values())
    why = (
        f"the guidance cascade's certified thrust {guided['force_x']:.4g} N and rudder {guided['rudder']:.4g} rad "
        f"{'fit' if ok else 'exceed'} the limits {act.tau_x:.4g} N and {act.rudder_max:.4g} rad "
        f"(binding: {channel}, {ratios[channel]:.3g} times its limit)"
    )
    return ActuatorCheck(
        act, None, channel, ratios[channel], ok, why, rudder_authority=authority, guided_peak=dict(guided)
    )


def rudder_check(
    point: DesignPoint, act: RudderActuation, peak: Peak | None, guided: Mapping[str, float] | None = None
) -> ActuatorCheck:
    """The refusal of the fully actuated law on a vehicle with a propeller and a rudder, with the figures.

    Parameters
    ----------
    point : DesignPoint
        The design (its envelope gives the top surge speed at which the rudder is strongest).
    act : RudderActuation
        The vehicle's propeller and rudder.
    peak : Peak or None
        The certified peak ``(|tau_x|, |tau_y|, |tau_psi|)`` the law would command (N, N, N m).
    guided : mapping or None
        With ``[guidance]``: the guidance certificate's ``{force_x, rudder}`` (N, rad), if any.
    """
    speed = float(point.config.envelope.u[1])
    sway, moment = act.authority(speed)
    authority = {"speed": speed, "side_force": sway, "moment": moment, "lever_arm": act.lever_arm}
    if point.config.guidance is not None:  # the guidance cascade runs: its certificate bounds thrust and rudder
        return guided_check(act, guided, authority)
    need = (
        ""
        if peak is None
        else f" (it needs |tau_y| <= {upper(peak[1], 4)} N with |tau_psi| <= {upper(peak[2], 4)} N m)"
    )
    why = (
        f"the formation law is fully actuated: it commands sway force and yaw moment independently{need}, and "
        f"this vehicle has no sway actuator: its rudder (+-{act.rudder_max:.4g} rad) gives sway force and yaw moment "
        f"only together (N = {act.lever_arm:.3g} m x Y), at most {sway:.3g} N with {moment:.3g} N m at {speed:.3g} m/s"
    )
    if act.note:
        why += f" ({act.note})"
    why += (
        '; steer this fleet with line-of-sight guidance instead: [guidance] kind = "ilos" runs a cascade that '
        "commands the propeller and the rudder, and certifies it (docs/guidance.md)"
    )
    return ActuatorCheck(act, peak, "force_y", None, False, why, rudder_authority=authority)


#: Why no force bound reaches the actuators when the law is sampled.
SAMPLED_UNBOUNDED = (
    "no certificate bounds the sampled law's commanded force: the composed certificate of the deployed loop "
    "does not hold (see composed), and the continuous law's force bounds do not hold the held, delayed, noisy one"
)


def sampled_law_peaks(ctx: PartContext) -> list[Peak] | None:
    """The force bounds of a sampled fully actuated law: the composed certificate's alone; ``None``: not sampled.

    The closed-loop, robust and implementation parts are about the continuous law or the model as
    the plant; only the composed certificate bounds the force the held law commands on delayed,
    noisy measurements, in the declared box and current. It bounds it when its fixed point holds,
    even when that force is what it refuses (it does not fit the actuators); when it has no fixed
    point (or it was waived for the parts it supersedes), no certificate bounds the force.

    Parameters
    ----------
    ctx : PartContext
        The design and the earlier parts' verdicts.
    """
    cfg = ctx.point.config
    composed = ctx.verdicts.get("composed")
    if composed is None or cfg.guidance is not None or not cfg.implementation.sampled:
        return None
    c = getattr(composed.detail, "certificate", None)
    force = getattr(c, "force", None)
    return [] if force is None else [force.as_tuple()]


@dataclass(frozen=True)
class ActuatorPart:
    """The certified peak force of every earlier part against the declared ``[actuators]``.

    It applies when limits are declared; without them it reports the peak and holds.
    """

    name: str = PART
    key: str | None = PART

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The actuator check of the peaks the earlier parts prove."""
        point = ctx.point
        guidance = ctx.verdicts.get("guidance")
        guided = None if guidance is None or not guidance.figures else guidance.figures.get("certified_peak")
        deployed = sampled_law_peaks(ctx)
        if deployed is None:
            act = check_actuators(point, ctx.peaks(), guided=guided)
        else:  # the continuous law's answers do not hold the sampled law's forces: the composed part answers
            act = check_actuators(point, deployed, answers=False, unbounded=SAMPLED_UNBOUNDED)
        if act.limits is None:
            return Verdict(self.name, True, False, (), act.to_dict(), detail=act)
        binding = None
        if act.binding is not None and act.binding_ratio is not None and act.binding_ratio >= ACTUATOR_BINDING_RATIO:
            binding = f"actuators ({act.binding}, {act.binding_ratio:.3g} times its limit)"
        if act.certified:
            return Verdict(self.name, True, True, (), act.to_dict(), binding=binding, detail=act)
        peak = act.certified_peak
        if isinstance(act.limits, RudderActuation) and point.config.guidance is not None:
            return Verdict(self.name, True, False, (), act.to_dict(), detail=act)  # the guidance part decides
        if isinstance(act.limits, RudderActuation):
            why = Reason(
                self.name,
                "unsupported",
                f"actuators: {act.reason}",
                channel="force_y",
                value=None if peak is None else peak[1],
                limit=0.0,
            )
            return Verdict(self.name, False, True, (why,), act.to_dict(), detail=act)
        limits = act.limits.limits()
        k = CHANNELS.index(act.binding) if act.binding in CHANNELS else None
        settings = advice(act.largest_certifiable)  # none for a sampled law: the composed part answers for it
        text = f"actuators: {act.reason}" + (f"; within the limits: {toml_line(settings)}" if settings else "")
        why = Reason(
            self.name,
            "thrust" if peak is not None else "not_covered",
            text,
            channel=act.binding,
            value=None if peak is None else (act.binding_ratio if k is None else peak[k]),
            limit=None if peak is None else (1.0 if k is None else limits[k]),
            settings=settings,
        )
        return Verdict(self.name, False, True, (why,), act.to_dict(), binding=binding, detail=act)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The certified peak force, the limits and what would fit them."""
        f = figures
        if f is None:
            return []
        peak = f["certified_peak"]
        if peak is None or peak.get("force_y") is None:  # none certified (a rudder's entries are null)
            return [f"  actuators                 {f['reason']}"]
        out = [
            f"  commanded force (certified) |tau_x| <= {upper(peak['force_x'], 5)} N, "
            f"|tau_y| <= {upper(peak['force_y'], 5)} N, "
            f"|tau_psi| <= {upper(peak['moment'], 5)} N m"
        ]
        lim = f["limits"]
        if lim is None:
            out.append(f"  actuators                 {f['reason']}")
            return out
        if f.get("kind") == "underactuated":
            out.append(
                f"  actuators (underactuated) propeller {lim['force_x']:.5g} N, rudder +-{lim['rudder']:.4g} rad: "
                "the fully actuated law is refused"
            )
            out.append(f"    {f['reason']}")
            return out
        verdict = "fit" if f["certified"] else "do NOT fit"
        out.append(
            f"  actuator limits           {lim['force_x']:.5g} N, {lim['force_y']:.5g} N, {lim['moment']:.5g} N m: "
            f"the peaks {verdict}"
        )
        if not f["certified"]:
            out.append(f"    {f['reason']}")
        best = f.get("largest_certifiable")
        if best is not None:
            if best.get("current_speed") is None:
                out.append(
                    "    largest certifiable within the limits: none (not even the nominal plant in still water)"
                )
            else:
                scale = "" if best.get("box_scale") is None else f"; the box scaled by {best['box_scale']:.4g}"
                words = ", ".join(s.words() for s in advice(best))
                out.append(f"    largest certifiable within the limits: {words} (re-run with these{scale})")
        return out

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """A condition never met on a vehicle with a rudder; else nothing (the certificates bound a run's force)."""
        act = ctx.point.config.actuators
        if not isinstance(act, RudderActuation):
            return None
        why = "the fully actuated law commands a sway force that this vehicle's rudder cannot make on its own"
        return RunCheck(self.name, "condition", True, False, why, refuses_gains=why)


__all__ = ["ActuatorCheck", "Peak", "check_actuators", "peak_of", "rudder_check"]
