"""The composed part of a certificate: the fleet as deployed, every declared effect at once.

With a sampled ``[implementation]`` (``sample_time > 0``) the law that runs is the held, delayed
law on noisy measurements, on a plant anywhere in the ``[uncertainty]`` box, in the declared
current. :func:`composed_summary` certifies exactly that loop for the design's gains
(:func:`~auv_hinf.composed.certificate.certify_deployed`), from the configured start, and holds
its force bound against the declared ``[actuators]`` (thruster set included).

**One route among two.** When the composed certificate covers, it *supersedes* the parts that
certify idealisations of the same loop (:attr:`ComposedPart.supersedes`: the continuous closed
loop, the continuous robust certificate and the implementation certificate of the nominal
plant): the assembly marks them as not applying, and the actuator and separation parts read the
composed bounds. When it does not cover, those parts decide as before, and the composed verdict
is waived if they all hold (the nominal implementation certificate may cover what the composed
one does not); otherwise its reasons say what would certify: the largest value of each declared
setting at which it covers (:mod:`auv_hinf.composed.advice`), each checked by a certificate.

Without a sample time the part does not apply: the continuous law has its own certificates.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from tqdm.auto import tqdm

from auv_hinf.actuation.thrust import ThrustBounds
from auv_hinf.certificate.deployed import ON_SLOT, deployed_problem
from auv_hinf.certificate.design_point import DesignPoint, design_point
from auv_hinf.certificate.mission_advice import CHANGE_WORDS, mission_advice, mission_changes, tried
from auv_hinf.certificate.part import FORMATION_LAW, ControlLaw, PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.parts.closed_loop import ON_SLOTS, full_heading_range
from auv_hinf.certificate.parts.implementation import ImplementationSummary, start_errors
from auv_hinf.certificate.parts.robust import run_outside
from auv_hinf.certificate.parts.separation import keeps_separation
from auv_hinf.certificate.reason import Reason, Setting, reason_from, toml_line, upper
from auv_hinf.composed.advice import (
    JOINT,
    NOISE_CHANNELS,
    TOGETHER,
    Advice,
    channels_put_back,
    declared_knobs,
    largest_covered,
    physical,
    rounded_down,
    shrunk,
)
from auv_hinf.composed.certificate import DeployedCertificate, DeployedProblem, certify_deployed
from auv_hinf.composed.loops import Errors
from auv_hinf.composed.reach import Reach, reach
from auv_hinf.config.settings import FormationConfig, with_settings
from auv_hinf.exceptions import AuvHinfError, DesignError
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.numerics.bisection import bisect
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR
from auv_hinf.robust.box import PARAMETERS

#: The part's registry name and JSON key.
PART = "composed"
#: The parts a covering composed certificate supersedes (they certify idealisations of its loop).
SUPERSEDES: tuple[str, ...] = ("closed_loop", "robust", "implementation")


@dataclass(frozen=True)
class ComposedSummary:
    """What ``certify`` reports under ``composed``.

    Attributes
    ----------
    applies : bool
        A sample time is declared (the part judges the sampled law).
    certificate : DeployedCertificate or None
        The composed certificate (``None``: it does not apply, or could not be computed).
    covers : bool
        It covers, and its force bound fits the declared actuators.
    reasons : tuple of str
        Why not (empty when it covers).
    advice : tuple of Advice
        For each declared setting, a value at which it covers (searched when it does not).
    start : Errors or None
        The configured start's errors in still water (the certificate adds the current's bound to
        the velocity error: ``problem.initial``, reported as ``start``).
    problem : DeployedProblem or None
        The problem it certifies.
    exact : tuple of Advice
        Answers that certify only with exact measurements (the noise at zero,
        :func:`~auv_hinf.composed.advice.physical`): kept out of ``advice``, and given, said so, only
        when no other answer is found.
    """

    applies: bool
    certificate: DeployedCertificate | None
    covers: bool
    reasons: tuple[str, ...]
    advice: tuple[Advice, ...] = ()
    start: Errors | None = None
    problem: DeployedProblem | None = None
    exact: tuple[Advice, ...] = ()

    @functools.cached_property
    def timing(self) -> Reach | None:
        """When it covers: the exact nominal limits of the sample time and delay at the design's gains.

        Computed on first use (:mod:`auv_hinf.composed.reach`, about half a second): the run
        checks, campaigns and advice probes that build a summary do not need it.
        """
        return reach(self.problem) if self.covers and self.problem is not None else None

    def covered_parts(self) -> list[str]:
        """What the certificate covers at once: the declared effects, by name."""
        p = self.problem
        if p is None:
            return []
        impl = p.implementation
        names = ["sample_time"]
        names += ["delay"] if impl.delay > 0.0 else []
        names += ["varying_delay"] if impl.varying_delay and impl.delay > 0.0 else []
        names += [] if impl.noise.exact else ["noise"]
        names += ["box"] if p.plant.box.declared else []
        names += ["current"] if p.plant.current > 0.0 else []
        names += ["current_rate"] if p.plant.current_rate > 0.0 else []
        names += ["integral"] if p.integral else []
        return names

    def decay_rate(self) -> float | None:
        """The nominal sampled loops' decay rate (1/s): ``-ln(rho)/h``, ``rho`` the slowest period map's radius."""
        c, p = self.certificate, self.problem
        if c is None or c.round is None or p is None:
            return None
        radius = max(g.radius for g in c.round.gains)
        return -math.log(radius) / p.implementation.sample_time if 0.0 < radius < 1.0 else None

    def to_dict(self) -> dict[str, Any]:
        """The ``composed`` object of ``certify --json`` (m, m/s, rad, rad/s, N, N m, 1/s)."""
        c = self.certificate
        errors = None
        if c is not None and c.errors is not None:  # a simulated run meets them to the integrator's accuracy
            errors = {k: max(v, NUMERICAL_FLOOR) for k, v in c.errors.to_dict().items()}
        return {
            "applies": self.applies,
            "covers": self.covers if self.applies else None,
            "parts": self.covered_parts(),
            "governed_by": None if c is None else c.governed_by,
            "reasons": list(self.reasons),
            "decay_rate": self.decay_rate(),
            "error_bounds": errors,
            "certified_peak": None if c is None or c.force is None else c.force.to_dict(),
            "operating_box": None if c is None or c.op is None else c.op.to_dict(),
            "small_gain": None if c is None else c.small_gain,
            "binding": [] if c is None else [{"coupling": t, "share": f} for t, f in c.binding],
            "start": None if self.problem is None else self.problem.initial.to_dict(),
            "current_speed": None if self.problem is None else self.problem.plant.current,
            "tightness": None if self.timing is None else self.timing.tightness,
            "timing": None if self.timing is None else self.timing.to_dict(),
            "implementation": None if self.problem is None else self.problem.implementation.to_dict(),
            "advice": [_advice_dict(a) for a in self.advice],
        }


def _words(channels: list[str]) -> str:
    """``["position", "yaw_rate"]`` as ``position and yaw rate`` (``a, b and c`` for three)."""
    names = [c.replace("_", " ") for c in channels]
    return f"{', '.join(names[:-1])} and {names[-1]}" if len(names) > 1 else names[0]


def _kept_channels(a: Advice) -> list[str]:
    """The declared noise channels a noise answer keeps at their declared bounds (of :data:`NOISE_CHANNELS`)."""
    if a.knob not in ("noise", "together") or not a.channels or a.original is None:
        return []
    declared = a.original.implementation.noise
    return [c for c in NOISE_CHANNELS if getattr(declared, c) > 0.0 and c not in a.channels]


def channel_fractions(a: Advice) -> dict[str, float]:
    """Each shrunk noise channel's advised bound over its declared one (empty unless a noise answer names channels).

    Parameters
    ----------
    a : Advice
        A covering answer.
    """
    if a.knob not in ("noise", "together") or not a.channels or a.original is None:
        return {}
    declared, advised = a.original.implementation.noise, a.problem.implementation.noise
    return {c: getattr(advised, c) / getattr(declared, c) for c in a.channels if getattr(declared, c) > 0.0}


def _advice_dict(a: Advice) -> dict[str, Any]:
    cert = a.certificate
    return {
        "setting": a.knob,
        "scaled": list(a.scaled),
        "scale": _written(a.scale),
        "channels": list(a.channels),
        "channel_scales": {c: _written(x) for c, x in channel_fractions(a).items()},
        "kept": _kept_channels(a),
        "settings": [s.to_dict() for s in advice_settings(a)],
        "position_bound": None if cert.errors is None else cert.errors.position,
    }


#: The share of the declared current and box (``world``) kept by an answer at which the answer that
#: shrinks the noise and delay with them is not searched too: below it the hardware kept as declared
#: leaves little of the box and current, and the other answer says what a faster, quieter loop buys.
#: A thirtysecond: the second answer's search and re-runs cost about 30 s on a refused BlueROV2 line
#: (48 s against 18 s), worth it when the first answer keeps almost nothing.
JOINT_ENOUGH = 1.0 / 32.0
#: Significant digits of an advised value: a scale's product (0.0875 x 0.125) is written 0.0109375, not
#: 0.010937500000000001; the re-run that confirms the advice (:func:`confirmed`) reads the written value.
ADVICE_SIGNIFICANT = 12


def advice_settings(a: Advice) -> tuple[Setting, ...]:
    """The configuration values of one piece of advice (the TOML tables and keys a user edits).

    Every number is written with :data:`ADVICE_SIGNIFICANT` significant digits.

    Parameters
    ----------
    a : Advice
        A covered value of one setting.
    """
    return tuple(Setting(s.table, s.key, _written(s.value)) for s in _advice_values(a))


def _written(value: Any) -> Any:
    """``value`` (a number or a list of numbers) with :data:`ADVICE_SIGNIFICANT` significant digits."""
    if isinstance(value, list):
        return [_written(v) for v in value]
    return float(f"{value:.{ADVICE_SIGNIFICANT}g}") if isinstance(value, float) else value


def _advice_values(a: Advice) -> tuple[Setting, ...]:
    """:func:`advice_settings` before rounding."""
    p = a.problem
    impl, plant = p.implementation, p.plant
    if len(a.scaled) > 1 or a.knob in JOINT:
        return tuple(s for k in a.scaled for s in _advice_values(replace(a, knob=k, scaled=(k,))))
    if a.knob == "noise":
        n = impl.noise
        return tuple(
            Setting("implementation.noise", k, getattr(n, k))
            for k in ("position", "velocity", "heading", "yaw_rate")
            if (getattr(n, k) > 0.0 or a.scale == 0.0) and (not a.channels or k in a.channels)
        )
    if a.knob == "delay":
        return (Setting("implementation", "delay", impl.delay),)
    if a.knob == "sample_time":
        return (Setting("implementation", "sample_time", impl.sample_time),)
    if a.knob == "current":
        out = [Setting("disturbance", "current_speed", plant.current)]
        if plant.current_rate > 0.0:
            out.append(Setting("disturbance", "current_rate", plant.current_rate))
        return tuple(out)
    box = plant.box
    moving = (box if a.original is None else a.original.plant.box).moving()
    return tuple(
        Setting("uncertainty", name, [box.lo[k], box.hi[k]]) for k, name in enumerate(PARAMETERS) if name in moving
    )


def composed_start(point: DesignPoint) -> Errors:
    """The configured start's errors against the raw mission in still water (m, m/s, rad, rad/s).

    The certificate adds the current's bound to the velocity error
    (:attr:`~auv_hinf.composed.certificate.DeployedProblem.initial`).

    Parameters
    ----------
    point : DesignPoint
        The design point (configured initial states, fleet, current bound).
    """
    b = start_errors(point)
    return Errors(b.position, b.velocity, b.heading, b.yaw_rate)


def within_actuators(point: DesignPoint) -> Callable[[DeployedProblem], DeployedCertificate]:
    """The composed certificate that also holds its force bound against ``point``'s declared actuators.

    Parameters
    ----------
    point : DesignPoint
        The design point (its configuration's actuators).
    """
    limits = point.config.force_limits

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        cert = certify_deployed(problem)
        if not cert.covers or limits is None or cert.force is None or limits.admits(cert.force.as_tuple()):
            return cert
        channel, ratio = limits.binding(cert.force.as_tuple())
        why = (
            f"the certified force (|tau_x| <= {upper(cert.force.force_x, 4)} N, "
            f"|tau_y| <= {upper(cert.force.force_y, 4)} N, "
            f"|tau_psi| <= {upper(cert.force.moment, 4)} N m) does not fit the actuators "
            f"({channel} at {ratio:.3g} times its limit)"
        )
        return replace(cert, covers=False, governed_by="actuators", reasons=(why,))

    return certify


def _applies(cfg: FormationConfig) -> bool:
    """The composed certificate is about ``cfg``: the formation law, sampled."""
    return cfg.guidance is None and cfg.implementation.sampled


def composed_summary(point: DesignPoint, *, search: bool = True) -> ComposedSummary:
    """The composed certificate of ``point``'s deployed loop from its configured start (see the module docstring).

    Parameters
    ----------
    point : DesignPoint
        The design point (configuration, gains, mission, tube).
    search : bool
        When it does not cover, search each declared setting's covered value (a few certificates each).
    """
    cfg = point.config
    if not _applies(cfg):
        return ComposedSummary(False, None, True, ())
    try:  # the composed certificate bounds the heading error, not the heading
        full_heading_range(cfg.envelope)
    except DesignError as exc:
        return ComposedSummary(True, None, False, (f"composed certificate not computed: {exc}",))
    if point.gains is None:
        return ComposedSummary(True, None, False, ("the design gives no gains to certify",))
    start = composed_start(point)
    certify = within_actuators(point)
    try:
        problem = deployed_problem(cfg, point.mission, point.tube, point.offsets, point.gains, start)
        cert = certify(problem)
        advice: tuple[Advice, ...] = ()
        if not cert.covers and search:
            found: list[Advice] = []
            for knob in declared_knobs(problem):
                if knob in JOINT and any(
                    physical(a.scale, a.scaled) and (a.knob not in JOINT or a.scale >= JOINT_ENOUGH) for a in found
                ):
                    break  # one setting alone (or the current and box together) certifies: no need for more
                a = largest_covered(problem, knob, certify)
                if knob == "noise" and cfg.synthesis == "deployed" and (a is None or not physical(a.scale, a.scaled)):
                    a = rerun_noise(cfg, problem) or a  # the design's gains hold no noise a vehicle has
                if a is not None:
                    found.append(a)
            advice = confirmed(cfg, problem, tuple(found), certify)
    except AuvHinfError as exc:
        return ComposedSummary(True, None, False, (f"composed certificate not computed: {exc}",), start=start)
    real = tuple(a for a in advice if physical(a.scale, a.scaled))
    exact = tuple(a for a in advice if not physical(a.scale, a.scaled))
    return ComposedSummary(True, cert, cert.covers, cert.reasons, real, start, problem, exact)


@dataclass(frozen=True)
class ComposedPart:
    """The deployed loop: box, current, thrusters, sample time, delay and noise at once."""

    name: str = PART
    key: str | None = PART
    #: The fully actuated formation law only (with ``[guidance]`` the assembly does not evaluate it).
    laws: tuple[ControlLaw, ...] = FORMATION_LAW
    #: The parts a covering composed certificate makes redundant (the assembly marks them).
    supersedes: tuple[str, ...] = SUPERSEDES

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The composed summary of ``ctx.point``: covers, or why not with what would certify."""
        cfg = ctx.point.config
        if _applies(cfg):
            try:  # the composed certificate bounds the heading error, not the heading
                full_heading_range(cfg.envelope)
            except DesignError as exc:
                refused = ComposedSummary(True, None, False, (str(exc),))
                why = reason_from(self.name, exc, "composed certificate not computed: ")
                return Verdict(self.name, False, True, (why,), refused.to_dict(), detail=refused)
        summary = composed_summary(ctx.point)
        figures = summary.to_dict()
        c = summary.certificate
        design = ctx.point.deployed_design
        binding = None if design is None else f"deployed design: {design.binding}"
        if not summary.applies:
            return Verdict(self.name, True, False, (), figures, detail=summary)
        if summary.covers and c is not None and c.force is not None and c.errors is not None:
            return Verdict(
                self.name,
                True,
                True,
                (),
                figures,
                peaks=(c.force.as_tuple(),),
                binding=binding,
                detail=summary,
                position_bound=float(c.errors.position),
            )
        # the reason's settings are one answer, written whole: the first (the advice's order puts what a
        # deployment changes most easily first); the others are alternatives, listed in the JSON's advice,
        # and writing two answers' values together would give one key two values
        settings = advice_settings(summary.advice[0]) if summary.advice else ()
        together = any(a.knob in JOINT for a in summary.advice)
        # each piece of advice is one answer, written whole (a knob may be several keys: the four noise bounds)
        hint = "; or ".join(_advice_line(a) for a in summary.advice)
        message = "composed certificate of the deployed loop does not cover: " + (
            "; ".join(summary.reasons) or "not certified"
        )
        if hint:
            if together and len(summary.advice) == 1:
                kept = "" if summary.advice[0].knob == "together" else ", the implementation as declared"
                lead = f"at the design's gains no one setting alone certifies; all of these together do{kept} (re-run)"
            elif together:
                lead = (
                    "at the design's gains no one setting alone certifies; each of these answers does, every value "
                    "of it written (re-run; the settings given are the first)"
                )
            elif len(summary.advice) == 1:
                lead = "this certifies, every value written"
            else:
                lead = (
                    "any one of these answers certifies on its own, every value of it written (the settings given are "
                    "the first)"
                )
            message += f" ({lead}: {hint})"
        elif summary.applies and summary.problem is not None:
            text, settings, entry = _no_advice(ctx.point, summary.problem, summary.exact)
            message += f" ({text})"
            if entry is not None:  # the JSON's advice lists every answer the text gives
                figures["advice"] = [entry]
        why = Reason(self.name, "not_covered", message, channel=None if c is None else c.governed_by, settings=settings)
        return Verdict(self.name, False, True, (why,), figures, binding=binding, detail=summary)

    def superseded_figures(self, name: str, figures: Any) -> Any:
        """The ``implementation`` and ``robust`` objects when the composed certificate covers them.

        The ``robust`` object says the declared box and current are covered by it
        (:func:`_robust_covered`). The ``implementation`` object is the declared implementation,
        covered: its error bounds are the composed ones (``covered_by: "composed"``), and its timing figures
        those of the composed certificate (:mod:`auv_hinf.composed.reach`): the certified sample
        time and delay (the declared ones: ``searched_sample_time`` false) and the exact nominal
        limits beside them.
        """
        if figures is None:
            return None
        if name == "robust":
            return _robust_covered(figures)
        if name != "implementation":
            return None
        declared = figures.get("implementation")
        if declared is None:
            return None
        noise = MeasurementNoise(**declared["noise"])
        impl = Implementation(declared["sample_time"], declared["delay"], declared["varying_delay"], noise)
        out = ImplementationSummary(impl, None, True, ()).to_dict()
        out.update({"error_bounds": figures["error_bounds"], "covered_by": PART})
        timing = figures.get("timing")
        if timing is not None:
            keys = ("max_sample_time", "max_delay", "exact_max_sample_time", "tightness")
            out.update({k: timing[k] for k in keys})
            out["decay_rate"] = figures.get("decay_rate")
        return out

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The deployed loop's verdict, bounds and force, or why not and what would certify."""
        f = figures
        if f is None or not f.get("applies"):
            return []
        out = [f"  composed (as deployed)    covers: {', '.join(f['parts'])}"]
        b, peak, op = f["error_bounds"], f["certified_peak"], f["operating_box"]
        if b is not None:
            out.append(
                f"    errors (whole run)      |e| <= {upper(b['position'], 3)} m, "
                f"|e'| <= {upper(b['velocity'], 3)} m/s, "
                f"|e_psi| <= {upper(b['heading'], 3)} rad, |e_r| <= {upper(b['yaw_rate'], 3)} rad/s"
            )
        if peak is not None:
            out.append(
                f"    commanded force         |tau_x| <= {upper(peak['force_x'], 4)} N, "
                f"|tau_y| <= {upper(peak['force_y'], 4)} N, "
                f"|tau_psi| <= {upper(peak['moment'], 4)} N m"
            )
        if op is not None:
            out.append(
                f"    envelope it needs       u in [{op['u_min']:.3g}, {op['u_max']:.3g}] m/s, "
                f"|v| <= {upper(op['v_max'], 3)} m/s, "
                f"|r| <= {upper(op['r_max'], 3)} rad/s"
            )
        t = f.get("timing")
        if t is not None:
            out.append(
                f"    timing                  certified at h = {t['max_sample_time']:.4g} s, "
                f"d = {t['max_delay']:.4g} s; exact nominal limits h < {_seconds(t['exact_max_sample_time'])}, "
                f"d < {_seconds(t['exact_max_delay'])}"
            )
        if f["covers"]:
            out.append("    composed covered        yes")
            return out
        out.append(f"    composed covered        NO: {'; '.join(f['reasons']) or 'not certified'}")
        for a in f.get("advice") or []:
            values = toml_line(Setting.from_dict(s) for s in a["settings"])
            what, kept, scale = a["setting"], "", f"{a['scale']:.3g}" if a.get("scale") is not None else ""
            if a.get("channels"):  # the noise of these channels, the others as declared
                what = f"{_words(a['channels'])} noise"
                kept = f"; the {_words(a['kept'])} noise as declared" if a.get("kept") else ""
                fractions = a.get("channel_scales") or {}
                if len({f"{x:.3g}" for x in fractions.values()}) > 1:  # each channel at its own fraction
                    groups: dict[str, list[str]] = {}  # the channels at one printed fraction together
                    for c, x in fractions.items():
                        groups.setdefault(f"{x:.3g}", []).append(c)
                    phrases = [f"{_words(cs)} noise at {x}" for x, cs in groups.items()]
                    what, scale = ", the ".join(phrases[:-1]) + " and the " + phrases[-1], ""
            if a["setting"] in JOINT:  # the noise named by its channels when some were put back
                names = [what if k == "noise" and a.get("channels") else k for k in a.get("scaled") or []]
                what = ", ".join(names) + " together"
            if a.get("scale") is None:  # a change of the design or the mission, not a declared value shrunk
                out.append(f"    certifies with          {values} (a change of the {what})")
            else:
                at = f" at {scale}" if scale else ""
                out.append(f"    certifies with          {values} (the {what}{at} of the declared{kept})")
        return out

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Does the composed certificate cover this run: plant in the box, current within the bound, start inside?"""
        point = ctx.point
        cfg = point.config
        if cfg.guidance is not None or not cfg.implementation.sampled:
            return None
        summary = composed_summary(point, search=False)
        c = summary.certificate
        why = "; ".join(summary.reasons)
        outside = run_outside(point, self.name, varying_current=True)
        covers = summary.covers and outside is None
        if outside is not None:
            why = outside.message
        bounds = thrust = None
        if c is not None and c.errors is not None and summary.covers:
            bounds = {k: max(v, NUMERICAL_FLOOR) for k, v in c.errors.to_dict().items()}
            thrust = None if c.force is None else ThrustBounds(*c.force.as_tuple())
        notes = () if covers else (f"composed certificate: {why or 'not covered'}",)
        return RunCheck(
            self.name,
            "certificate",
            True,
            covers,
            why or "covered",
            notes,
            bounds=bounds,
            thrust=thrust,
            refuses_gains=_gains_refusal(point, summary),
            certifies_gains=summary.covers,
            detail=summary,
        )


def _gains_refusal(point: DesignPoint, summary: ComposedSummary) -> str | None:
    """Why the composed certificate does not cover the gains even from the slots, or ``None``.

    The deployed loop is the composed certificate's to judge: gains it refuses with every vehicle
    on its slot are refused whatever the run's start (``simulate`` and ``campaign`` then need
    ``--uncertified``). A configured start it does not cover is the run's matter, not the gains'.
    """
    problem = summary.problem
    if summary.covers or problem is None:
        return None
    on_slots = problem if problem.start == ON_SLOT else replace(problem, start=ON_SLOT)
    cert = within_actuators(point)(on_slots)
    if cert.covers:
        return None
    return f"the composed certificate of the deployed loop does not cover them: {'; '.join(cert.reasons)}"


def _robust_covered(figures: Mapping[str, Any]) -> dict[str, Any]:
    """The ``robust`` object when the composed certificate covers: the declared box and current, covered by it.

    Its bounds are the composed whole-run bounds (which also bound the errors' ultimate values) and
    its thrust the composed force bound; the continuous law's invariant sets are not computed.
    """
    covered = figures.get("parts") or []
    return {
        "declared": any(k in covered for k in ("box", "current", "current_rate", "integral")),
        "stable": True,
        "covers": True,
        "covered_by": PART,
        "decay_rate": figures.get("decay_rate"),
        "ultimate_bounds": figures.get("error_bounds"),
        "error_bounds": figures.get("error_bounds"),
        "margin": None,
        "worst_vertex": None,
        "gains": None,
        "design": None,
        "details": None,
        "reasons": [],
        "box_declared": "box" in covered,
        "current_speed": figures.get("current_speed"),
        "thrust": figures.get("certified_peak"),
    }


def rerun(cfg: FormationConfig, settings: tuple[Setting, ...]) -> ComposedSummary | None:
    """The covering composed summary of ``cfg`` rewritten with ``settings``, or ``None`` when it does not cover.

    The configuration is rewritten (:func:`~auv_hinf.config.settings.with_settings`), designed and
    certified from its configured start, as a re-run with those settings is: a robust or deployed
    design chooses its gains again for the new settings. A re-run whose certified position bound
    leaves two vehicles closer than ``[formation] min_separation`` is not one that certifies, and
    counts as not covering (:func:`~auv_hinf.certificate.parts.separation.keeps_separation`).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    settings : tuple of Setting
        The values to write into it.
    """
    try:
        # a design none of whose candidates covers is not an answer, whatever gains would then run
        point = design_point(with_settings(cfg, [(s.table, s.key, s.value) for s in settings]), fallback=False)
        summary = composed_summary(point, search=False)
    except AuvHinfError:  # an invalid combination, or a design that fails: not an answer
        return None
    c = summary.certificate
    if not summary.covers or c is None or c.errors is None or summary.problem is None:
        return None
    if not keeps_separation(point, float(c.errors.position)):
        return None
    return summary


def covered_position_bound(cfg: FormationConfig, settings: tuple[Setting, ...]) -> float | None:
    """The composed position bound (m) of ``cfg`` re-run with ``settings`` (:func:`rerun`), or ``None``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    settings : tuple of Setting
        The values a re-run writes into it (``[table] key = value``).
    """
    summary = rerun(cfg, settings)
    if summary is None or summary.certificate is None or summary.certificate.errors is None:
        return None
    return float(summary.certificate.errors.position)


#: Fractions of an advised scale tried, each as a re-run computes it, when a re-run at the advised
#: scale itself does not cover (its design chose other gains than the ones the advice was found
#: with); 0 is the setting's smallest value.
CONFIRM_FRACTIONS = (0.5, 0.25, 0.0)
#: Scales of the declared noise, delay, current and box tried together, each as a re-run computes
#: it, when none covers at the design's gains (the re-run's design may cover where they do not).
RERUN_TOGETHER = (0.5, 0.25, 0.125, 0.0625, 0.0)
#: Fractions of the declared sample time tried, each re-run with the noise, delay, current and box
#: at nothing, when none of :data:`RERUN_TOGETHER` covers.
RERUN_SAMPLE_TIME = (0.5, 0.25)
#: Steps of the geometric bisection of a longer sample time after an advised one covers, with the
#: re-run's gains (one certificate each, then one re-run): the advice is found with the design's
#: gains, and a re-run designs its gains for the shorter sample time, which may hold a longer one (a
#: 5 Hz fleet advised 100 Hz at the design's gains certified at 8 Hz with its own). Four steps put the
#: answer within a factor ``(1 / scale)^(1/16)`` of the longest (1.2 from 5 % of the declared).
SAMPLE_TIME_CLIMBS = 4


def _as_rerun(cfg: FormationConfig, a: Advice) -> Advice | None:
    """``a`` with the re-run's problem and certificate, when a re-run with its settings covers."""
    summary = rerun(cfg, advice_settings(a))
    if summary is None or summary.problem is None or summary.certificate is None:
        return None
    return replace(a, problem=summary.problem, certificate=summary.certificate)


def confirmed(
    cfg: FormationConfig,
    problem: DeployedProblem,
    advice: tuple[Advice, ...],
    certify: Callable[[DeployedProblem], DeployedCertificate] = certify_deployed,
) -> tuple[Advice, ...]:
    """The advice that re-running certifies: each piece checked as a re-run computes it.

    The advice is found with the design's gains; a re-run designs its gains again for the new
    settings (a robust or deployed design), so each piece is re-run: kept when it covers, else
    shrunk further (:data:`CONFIRM_FRACTIONS` of its scale) until a re-run covers, else dropped.
    The settings shrunk together are first re-run at the larger scales of :data:`RERUN_TOGETHER`,
    largest first (the re-run's gains may cover more than the design's). A confirmed sample time
    climbs with the re-run's gains (:func:`_climbed`), and a confirmed noise of a deployed design
    by re-runs (:func:`_climbed_by_reruns`). Every piece returned carries the re-run's problem and
    certificate (its gains and bounds).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    problem : DeployedProblem
        Its composed problem (the design's gains), which does not cover.
    advice : tuple of Advice
        The advice found at the design's gains.
    certify : callable
        The certificate the advice was found with (:func:`within_actuators`): an advised sample time
        climbs with it (:func:`_climbed`).
    """
    out: list[Advice] = []
    with tqdm(total=len(advice), unit="answer", desc="advice re-runs", leave=False) as bar:
        for a in advice:
            bar.update(1)
            original = a.original or problem
            if a.knob == "together":  # larger scales first: the re-run's own gains may cover more
                larger = [x for x in RERUN_TOGETHER if x > a.scale]
                above = next(filter(None, (_as_rerun(cfg, _scaled(a, original, x)) for x in larger)), None)
                if above is not None:
                    out.append(hardware_put_back(cfg, above, original))
                    continue
            for scale in dict.fromkeys((a.scale, *(a.scale * f for f in CONFIRM_FRACTIONS))):
                got = _as_rerun(cfg, a if scale == a.scale else _scaled(a, original, scale))
                if got is not None:
                    if a.knob == "sample_time":
                        got = _climbed(cfg, got, original, certify)
                    elif a.knob == "noise" and cfg.synthesis == "deployed":
                        got = _climbed_by_reruns(cfg, got, original, certify)
                    elif a.knob == "together":
                        got = hardware_put_back(cfg, got, original)
                    out.append(got)
                    break
    return tuple(out)


def _held_rerun(cfg: FormationConfig, trial: Advice) -> Advice | None:
    """:func:`_as_rerun` of ``trial``, tried only when the gains of the re-run it comes from still cover it.

    ``trial`` is a covering re-run with one more hardware setting put back; its problem keeps that
    re-run's gains. When they do not cover it (one certificate) the trial is not re-run (a full
    design, 30 certificates when none of its candidates covers): a setting that only other gains
    would hold is left shrunk. Nothing is claimed without the re-run itself.
    """
    if not certify_deployed(trial.problem).covers:
        return None
    return _as_rerun(cfg, trial)


def hardware_put_back(cfg: FormationConfig, a: Advice, original: DeployedProblem) -> Advice:
    """``a`` (a covering re-run of settings shrunk ``together``) with the hardware put back where a re-run holds it.

    The delay, then each noise channel in :data:`~auv_hinf.composed.advice.NOISE_CHANNELS` order (the
    dearest first), is put back at its declared value, the rest as ``a`` has them, and kept there when
    a re-run covers (one re-run each, tried when the current gains still cover: :func:`_held_rerun`):
    the answer then shrinks the hardware only where it must, with the current and the box. ``a`` is
    returned unchanged at scale 0 (nothing is left to keep).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    a : Advice
        A covering re-run of the ``together`` knob.
    original : DeployedProblem
        The problem as declared.
    """
    if a.knob != "together" or a.scale <= 0.0:
        return a
    best = a
    declared = original.implementation
    if "delay" in best.scaled and len(best.scaled) > 1 and declared.delay > 0.0:
        impl = replace(best.problem.implementation, delay=declared.delay)
        trial = replace(
            best,
            problem=replace(best.problem, implementation=impl),
            scaled=tuple(k for k in best.scaled if k != "delay"),
        )
        best = _held_rerun(cfg, trial) or best
    if "noise" not in best.scaled:
        return best
    shrinking = tuple(c for c in NOISE_CHANNELS if getattr(declared.noise, c) > 0.0)

    def holds(rest: tuple[str, ...]) -> bool:
        nonlocal best
        values = {c: getattr(declared.noise, c) * (best.scale if c in rest else 1.0) for c in shrinking}
        impl = replace(best.problem.implementation, noise=replace(best.problem.implementation.noise, **values))
        scaled = best.scaled if rest else tuple(k for k in best.scaled if k != "noise")
        trial = replace(best, problem=replace(best.problem, implementation=impl), scaled=scaled, channels=rest)
        got = _held_rerun(cfg, trial)
        if got is not None:
            best = got
        return got is not None

    # every channel may go back when something else stays shrunk (the current, the box)
    channels_put_back(shrinking, holds, last=len(best.scaled) > 1)
    return best


def _climbed(
    cfg: FormationConfig,
    a: Advice,
    original: DeployedProblem,
    certify: Callable[[DeployedProblem], DeployedCertificate],
) -> Advice:
    """``a`` (a covering re-run) at a longer sample time that a re-run covers too, when there is one.

    The advice is found with the design's gains; the re-run designs its gains for the shorter sample
    time, and they may hold a longer one. A geometric bisection between ``a``'s scale and the declared
    one (refused) with the re-run's gains (:data:`SAMPLE_TIME_CLIMBS` certificates) finds it, and one
    re-run there confirms it (its design covers: the re-run's gains are among its candidates); when
    the re-run does not cover, ``a`` is kept.
    """
    gains = a.problem.gains

    def covers(scale: float) -> bool:
        return certify(replace(shrunk(original, "sample_time", scale), gains=gains)).covers

    longer = bisect(covers, a.scale, 1.0, steps=SAMPLE_TIME_CLIMBS, geometric=True)[0]
    if longer <= a.scale:
        return a
    got = _as_rerun(cfg, _scaled(a, original, longer))
    return a if got is None else got


#: Steps of the geometric bisection of a larger noise after an advised one is confirmed, each a re-run
#: with its own deployed design: the advice is found with the design's gains, and a re-run's design
#: may choose gains of a lower bandwidth that hold a much larger noise (a BlueROV2 line refused at
#: 0.6 m of position noise, advised 0.0375 m at the design's gains, certified 0.3 m with its own).
#: Three re-runs (about 4 s each on that line) put the answer within a factor ``(1 / scale)^(1/8)``
#: of the largest the re-runs cover.
NOISE_CLIMBS = 3


def _climbed_by_reruns(
    cfg: FormationConfig,
    a: Advice,
    original: DeployedProblem,
    certify: Callable[[DeployedProblem], DeployedCertificate],
) -> Advice:
    """``a`` (a covering re-run of the noise) with the channels a re-run holds put back, and the rest raised.

    The answer was refined with the design's gains (:func:`~auv_hinf.composed.advice.refined_noise`);
    a re-run designs others, which may hold more. Each channel it still shrinks, in
    :data:`~auv_hinf.composed.advice.NOISE_CHANNELS` order, is put back at its declared bound when the
    re-run's gains cover so (one certificate each, confirmed by one re-run: the re-run's design then
    covers, those gains being among its candidates), else when a re-run with it put back covers (its
    design choosing other gains). The channels left are then raised together by a geometric
    bisection of re-runs (:data:`NOISE_CLIMBS`) below ``a.ceiling`` (a scale a re-run refused), at
    scales rounded down
    (:func:`~auv_hinf.composed.advice.rounded_down`). ``a`` is kept when nothing better is confirmed,
    and when it is the noise at zero (not an answer a vehicle can follow,
    :func:`~auv_hinf.composed.advice.physical`).
    """
    if a.scale <= 0.0:
        return a
    declared = original.implementation.noise
    shrinking = tuple(c for c in NOISE_CHANNELS if getattr(declared, c) > 0.0 and (not a.channels or c in a.channels))
    best = a
    cheap = channels_put_back(
        shrinking,
        lambda rest: certify(replace(shrunk(original, "noise", a.scale, rest), gains=a.problem.gains)).covers,
    )
    if len(cheap) < len(shrinking):
        got = _as_rerun(cfg, _scaled(replace(a, channels=cheap), original, a.scale))
        if got is not None:
            best, shrinking = got, cheap

    def reruns(rest: tuple[str, ...]) -> bool:
        nonlocal best
        got = _as_rerun(cfg, _scaled(replace(best, channels=rest), original, a.scale))
        if got is not None:
            best = got
        return got is not None

    start = replace(best, channels=channels_put_back(shrinking, reruns))
    best = replace(best, channels=start.channels)  # named even when none was put back (each may climb alone)

    def covers(scale: float) -> bool:
        nonlocal best
        scale = rounded_down(scale)
        if scale <= start.scale:
            return True
        got = _as_rerun(cfg, _scaled(start, original, scale))
        if got is not None and scale > best.scale:
            best = got
        return got is not None

    bisect(covers, start.scale, max(start.ceiling, start.scale), steps=NOISE_CLIMBS, geometric=True)
    left = best.channels or shrinking
    if len(left) > 1:  # the channels bind by different amounts: each climbs on its own, the dearest first
        for channel in left:
            best = _channel_climbed(cfg, best, original, channel)
    return best


def _channel_climbed(cfg: FormationConfig, a: Advice, original: DeployedProblem, channel: str) -> Advice:
    """``a`` (a covering re-run of the noise) with ``channel`` raised alone as far as re-runs cover.

    The other channels stay as ``a`` has them; a geometric bisection of re-runs
    (:data:`NOISE_CLIMBS`) between the channel's present fraction of its declared bound and 1 (the
    declared bound was refused when the channels were put back, with the others lower than now),
    at fractions rounded down (:func:`~auv_hinf.composed.advice.rounded_down`). ``a.scale`` stays the
    fraction the channels were found at together; each channel's own is its value over its declared
    bound (:func:`channel_fractions`).
    """
    declared = getattr(original.implementation.noise, channel)
    present = getattr(a.problem.implementation.noise, channel)
    if not declared > 0.0 or present >= declared:
        return a
    best = a

    def covers(fraction: float) -> bool:
        nonlocal best
        fraction = rounded_down(fraction)
        if fraction * declared <= present:
            return True
        noise = replace(best.problem.implementation.noise, **{channel: fraction * declared})
        trial = replace(
            best, problem=replace(best.problem, implementation=replace(best.problem.implementation, noise=noise))
        )
        got = _as_rerun(cfg, trial)
        if got is not None:
            best = got
        return got is not None

    bisect(covers, present / declared, 1.0, steps=NOISE_CLIMBS, geometric=True)
    return best


def _scaled(a: Advice, original: DeployedProblem, scale: float) -> Advice:
    """``a`` at another ``scale`` of the declared ``original`` (its certificate left as found)."""
    return replace(a, scale=scale, problem=shrunk(original, a.knob, scale, a.channels))


#: Scales of the declared noise (every channel) tried in turn, each as a re-run computes it, when no
#: noise a vehicle can have covers at the design's gains: the design chose its gains for the declared
#: noise, and a re-run's design for a smaller one may hold far more than those gains do (a BlueROV2
#: line declaring 50 m of position noise was advised 0.0017 of the noise and the delay together;
#: with these re-runs, 0.28 m of position noise with the rest as declared). Each step is an eighth,
#: down to 8^-10 (about 1e-9: a declared noise that far off is a units slip); the confirmed answer
#: then climbs below the last scale refused (:func:`_climbed_by_reruns`, three steps: within a
#: factor 8^(1/8) = 1.3 of the largest the re-runs cover). Each is rounded down
#: (:func:`~auv_hinf.composed.advice.rounded_down`), as every advised scale is.
RERUN_NOISE = tuple(0.125**k for k in range(1, 11))


def rerun_noise(cfg: FormationConfig, problem: DeployedProblem) -> Advice | None:
    """The declared noise shrunk (every channel by one scale) as far as a re-run certifies, or ``None``.

    For a deployed design whose gains hold no noise a vehicle can have: the scales
    :data:`RERUN_NOISE` are tried in turn, each a re-run that designs its own gains, after the
    smallest (when a re-run refuses it, none is tried and there is no answer); the first that
    covers is returned, with the re-run's problem and certificate. :func:`confirmed` then puts
    back the channels that need not shrink and raises the others.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    problem : DeployedProblem
        Its composed problem, which does not cover.
    """
    if problem.implementation.noise.exact:
        return None
    scales = [rounded_down(x) for x in RERUN_NOISE]
    # each candidate's ceiling is the scale before it, which a re-run refused when it is tried
    candidates = [
        Advice("noise", x, shrunk(problem, "noise", x), _UNTRIED, ("noise",), problem, ceiling=above)
        for x, above in zip(scales, [1.0, *scales[:-1]], strict=True)
    ]
    # less noise never loses the cover at fixed gains, and a re-run's search finds covering gains
    # whenever a candidate covers: when the smallest scale is refused, every larger one would be (one
    # re-run instead of ten on a fleet whose box or current binds, 14 s of a 22 s refusal)
    smallest = _as_rerun(cfg, candidates[-1])
    if smallest is None:
        return None
    return _first_rerun(cfg, candidates[:-1], "noise re-runs") or smallest


#: The certificate of an answer not yet re-run: the design's gains do not cover it, a re-run designs its own.
_UNTRIED = DeployedCertificate(False, None, ("at the design's gains: the re-run designs its own",))


def _first_rerun(cfg: FormationConfig, candidates: list[Advice], what: str) -> Advice | None:
    """The first of ``candidates`` a re-run covers (with the re-run's problem and certificate), or ``None``."""
    with tqdm(total=len(candidates), unit="re-run", desc=what, leave=False) as bar:
        for cand in candidates:
            bar.update(1)
            got = _as_rerun(cfg, cand)
            if got is not None:
                return got
    return None


def rerun_together(cfg: FormationConfig, problem: DeployedProblem) -> Advice | None:
    """The declared noise, delay, current and box shrunk together as far as a re-run certifies, or ``None``.

    For when nothing covers at the design's gains: a re-run designs its gains again, and may cover
    where they do not. The scales :data:`RERUN_TOGETHER` are tried in turn; the first that covers
    is returned, with the re-run's problem and certificate.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration as declared.
    problem : DeployedProblem
        Its composed problem, which does not cover.
    """
    knobs = declared_knobs(problem)
    scaled = tuple(k for k in TOGETHER if k in knobs)
    if not scaled:
        return None
    candidates = [
        Advice("together", x, shrunk(problem, "together", x), _UNTRIED, scaled, problem) for x in RERUN_TOGETHER
    ]
    # with all of them gone the sample time binds: a faster law with them at nothing
    nothing = shrunk(problem, "together", 0.0)
    candidates += [
        Advice("together", 0.0, shrunk(nothing, "sample_time", f), _UNTRIED, (*scaled, "sample_time"), problem)
        for f in RERUN_SAMPLE_TIME
    ]
    return _first_rerun(cfg, candidates, "advice re-runs")


def _change_entry(what: str, settings: tuple[Setting, ...], bound: float) -> dict[str, Any]:
    """The ``composed.advice`` entry of a change that is not a declared value shrunk (``scale`` None)."""
    return {
        "setting": what,
        "scaled": [],
        "scale": None,
        "settings": [s.to_dict() for s in settings],
        "position_bound": bound,
    }


def _no_advice(
    point: DesignPoint, problem: DeployedProblem, exact: tuple[Advice, ...] = ()
) -> tuple[str, tuple[Setting, ...], dict[str, Any] | None]:
    """What certifies when no declared setting does at the design's gains: the start, design, mission or a re-run.

    A declared ``[simulation] initial`` off the slots is tried first, removed (every vehicle on its
    slot). The design or mission changes of :func:`~auv_hinf.certificate.mission_advice.mission_advice`
    come first; when none covers, the declared settings shrunk together with the gains a re-run
    designs (:func:`rerun_together`). Returns the sentence, the settings, and the entry of the
    ``composed.advice`` list of ``certify --json`` (``setting`` is ``start``, ``design``, ``turns``,
    ``speed`` or ``together``; ``None`` when nothing certifies). An answer that needs exact
    measurements (``exact``: the search's answers with the noise at zero, or the re-run's settings
    shrunk together to nothing) comes last, said so (:data:`EXACT_ONLY`).
    """
    if point.config.simulation.initial is not None:
        # a declared start off the slots may be all that binds: the hardware and the world stay as declared
        bound = covered_position_bound(point.config, (ON_SLOTS,))
        if bound is not None:
            return (
                f"the declared start binds: every vehicle started on its slot certifies ({ON_SLOTS.toml()}; "
                f"certified |e| <= {upper(bound, 3)} m)",
                (ON_SLOTS,),
                _change_entry("start", (ON_SLOTS,), bound),
            )
    found = mission_advice(point, covered_position_bound)
    if found:
        a = found[0]
        return (
            "at the design's gains no declared setting certifies when shrunk, even all together; "
            f"this certifies, {CHANGE_WORDS[a.what]}: {a.line()}",
            a.settings,
            _change_entry(a.what, a.settings, a.position_bound),
        )
    together = rerun_together(point.config, problem)
    if together is not None and physical(together.scale, together.scaled):
        together = hardware_put_back(point.config, together, problem)
    if together is not None and not physical(together.scale, together.scaled):
        exact = (*exact, together)
        together = None
    if together is not None and together.certificate.errors is not None:
        bound = together.certificate.errors.position
        return (
            f"no declared setting certifies when shrunk at the design's gains, and neither do {tried(point.config)}; "
            f"with the gains a re-run designs, these values of {', '.join(together.scaled)} certify: "
            f"{_advice_line(together)} (certified |e| <= {upper(bound, 3)} m)",
            advice_settings(together),
            _advice_dict(together),
        )
    mixed = _mission_together(point)
    if mixed is not None and (mixed[3] or not exact):
        what, both, bound, phys = mixed
        lead = "" if phys else f"{EXACT_ONLY}, "
        return (
            f"no declared setting certifies when shrunk, even all together, and neither do {tried(point.config)}; "
            f"{lead}{CHANGE_WORDS[what]} with the declared settings shrunk together certify: {toml_line(both)} "
            f"(certified |e| <= {upper(bound, 3)} m)",
            both,
            _change_entry(what, both, bound),
        )
    if exact:  # the last resort: exact measurements, said so
        first = exact[0]
        return (
            f"at the design's gains no declared setting certifies when shrunk to a value a vehicle can have, and "
            f"neither do {tried(point.config)}; {EXACT_ONLY}: {_advice_line(first)}",
            advice_settings(first),
            _advice_dict(first),
        )
    return (
        f"at the design's gains no declared setting certifies when shrunk, even all together, and neither do "
        f"{tried(point.config)}: "
        "nothing tried certifies this loop (a faster [implementation] sample_time with a shorter delay, or other "
        "gains, may; none was found)",
        (),
        None,
    )


def _mission_together(point: DesignPoint) -> tuple[str, tuple[Setting, ...], float, bool] | None:
    """A change of the mission with the declared settings shrunk together, for when neither certifies alone.

    The first kind of :func:`~auv_hinf.certificate.mission_advice.mission_changes` (wider turns,
    or a slower mission on a line) at its gentlest: the changed configuration's declared noise,
    delay, current and box are shrunk together as a re-run certifies them
    (:func:`rerun_together`), and the change and those values together are confirmed by a re-run
    of the declared configuration as written. Returns the kind, the settings, the certified
    position bound (m) and whether the values are physical (:func:`physical`), or ``None``.
    """
    cfg = point.config
    changes = mission_changes(cfg)
    if not changes:
        return None
    kind = changes[0][0]
    settings = [s for what, s in changes if what == kind][-1]
    try:
        changed = with_settings(cfg, [(x.table, x.key, x.value) for x in settings])
        problem = composed_summary(design_point(changed), search=False).problem
    except AuvHinfError:
        return None
    together = None if problem is None else rerun_together(changed, problem)
    if together is None:
        return None
    both = settings + advice_settings(together)
    bound = covered_position_bound(cfg, both)
    return None if bound is None else (kind, both, bound, physical(together.scale, together.scaled))


#: How an answer that needs exact measurements is introduced: it certifies on re-run, but no
#: navigation measures without error.
EXACT_ONLY = (
    "only exact measurements certify, which no navigation gives (the bounds are then those of a loop that never "
    "leaves its slot): better navigation, a faster sample time or a shorter delay is needed; with exact ones"
)


def _advice_line(a: Advice) -> str:
    return toml_line(advice_settings(a))


def _seconds(x: float | None) -> str:
    return "none found" if x is None else f"{x:.4g} s"


__all__ = [
    "CONFIRM_FRACTIONS",
    "EXACT_ONLY",
    "JOINT_ENOUGH",
    "PART",
    "RERUN_NOISE",
    "RERUN_SAMPLE_TIME",
    "RERUN_TOGETHER",
    "SAMPLE_TIME_CLIMBS",
    "SUPERSEDES",
    "ComposedSummary",
    "advice_settings",
    "channel_fractions",
    "composed_start",
    "composed_summary",
    "confirmed",
    "covered_position_bound",
    "hardware_put_back",
    "rerun",
    "rerun_noise",
    "rerun_together",
    "within_actuators",
]
