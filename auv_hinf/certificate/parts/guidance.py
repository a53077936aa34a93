"""The guidance part: the certificate of the line-of-sight cascade of a propeller-and-rudder fleet.

A configuration with a ``[guidance]`` table steers every vehicle with the cascade of
:mod:`auv_hinf.guidance.law` (ILOS on its slot path, along-track speed coordination, surge and
heading autopilots on the propeller and the rudder), not with the fully actuated formation law.
This part builds the cascade's certificate problem from the configuration
(:func:`cascade_problem`: the ``[uncertainty]`` box, the ``[disturbance]`` current, the
propeller and rudder limits, every slot's speed, acceleration and jerk along the mission, the
sample time, the configured start) and proves it with
:func:`~auv_hinf.cascade.certificate.certify_cascade`: bounds of every vehicle's along-track,
cross-track and heading errors, of the sway speed, and of the commanded thrust and rudder, which
must fit the limits. Its figures are the ``guidance`` object of ``certify --json``.

When it does not hold, the part answers with the start on the slots when a declared ``[simulation]
initial`` is what binds, else with gains that certify the declared box and current
(a faster heading loop, a longer lookahead: :data:`GAIN_CANDIDATES`), else the largest current
and the largest scale of the box that certify (each with the other as declared; a bisection on
certificates, so the answer itself is certified), as ``settings`` to re-run with. When none of
these certifies, it shrinks the current and the box together on the declared mission (when the
nominal plant in still water certifies it), and tries the mission's changes
(:func:`~auv_hinf.certificate.mission_advice.mission_changes`: wider turns, a slower mission, both)
with the declared box and current, else with the two scaled together (:func:`mission_answer`);
a change of the mission is preferred only when it certifies much more of them
(:data:`MISSION_OVER_TOGETHER`). Every answer is the rewritten configuration's own certificate, as
a re-run computes it.

The certificate covers what ``simulate`` runs: the cascade sampled every ``[implementation]
sample_time`` (10 Hz by default), on measurements ``[implementation] delay`` seconds old with
errors within ``[implementation.noise]``, ILOS guidance. A varying delay, or plain LOS, is
answered "not evaluated", with the reason.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.cascade.certificate import (
    STATES,
    CascadeCertificate,
    CascadeProblem,
    certify_cascade,
    current_cells_apply,
    into_current_start,
    start_states,
)
from auv_hinf.certificate.deployed import deployed_plant, mission_jerks
from auv_hinf.certificate.design_point import DesignPoint, design_point, raw_fleet
from auv_hinf.certificate.mission_advice import CHANGE_WORDS, mission_changes
from auv_hinf.certificate.part import RUN_RTOL, PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.parts.closed_loop import ON_SLOTS
from auv_hinf.certificate.parts.robust import run_settings
from auv_hinf.certificate.parts.separation import (
    ADVICE_MARGIN,
    keeps_separation,
    separation_with,
    spread_factor,
    spread_settings,
)
from auv_hinf.certificate.reason import Reason, Setting, apart, toml_line, upper
from auv_hinf.composed.advice import rounded_down
from auv_hinf.composed.certificate import MAX_DELAY_SAMPLES
from auv_hinf.composed.loops import Plant
from auv_hinf.config.settings import FormationConfig, SimulationConfig, with_settings
from auv_hinf.exceptions import ConfigError
from auv_hinf.guidance.law import GuidanceConfig, SlotMotion
from auv_hinf.guidance.simulation import STEP, cascade_period, slot_motion
from auv_hinf.implementation.peak import in_flight
from auv_hinf.mission.paths import CircleReference, LawnmowerReference, LineReference
from auv_hinf.mission.tubes import slot_bounds
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.bisection import bisect, largest_holding
from auv_hinf.numerics.progress import PROGRESS_DELAY
from auv_hinf.robust.box import PARAMETERS

#: The part's registry name.
PART = "guidance"
#: The JSON key of its figures.
KEY = "guidance"
#: Bisection steps of the advised current and box scale (each halves the bracket: 2^-10 of it).
ADVICE_STEPS = 10
#: The centre paths whose speed is constant by construction (their ``speed`` parameter).
CONSTANT_SPEED_PATHS = (LineReference, CircleReference, LawnmowerReference)
#: Decimals of an advised value (rounded towards the certified side).
ADVICE_DIGITS = 4
#: Gains tried when the declared ones do not certify, as (heading bandwidth, lookahead) multipliers
#: of the declared ones, gentlest first: a faster heading loop rejects more of the residuals that
#: drive the heading and the sway, and a longer lookahead slows the cross-track loop's coupling to
#: them (docs/derivations/guidance.md). The last keeps the heading loop: when the sample time
#: allows no faster one (:data:`MAX_BANDWIDTH_STEP`), a longer lookahead alone may still certify (a
#: REMUS-like line at 2.4 rad/s and 10 Hz in a boxed 0.2 m/s current: 8 m refused, 16 m certified).
GAIN_CANDIDATES = ((2.4, 1.0), (2.4, 2.0), (3.2, 2.0), (1.0, 2.0))
#: The answer that starts every vehicle on its slot, heading into the current: the declared
#: ``[simulation] initial`` removed (the closed-loop part's own answer to a start it does not cover).
RESTART = ON_SLOTS
#: Why a mission on which a slot stops (a path-frame slot inside a turn) is not evaluated: the
#: refusal then answers with a change of the mission (:func:`mission_answer`).
SLOT_STOPS = "a slot stops (or runs backwards) on the mission: line-of-sight guidance needs a slot moving forwards"
#: Bisection steps of the joint scale of the current and the box, on the declared or a changed
#: mission (2^-6 of it): each step is one certificate, and the answer is certified once more as
#: written.
MISSION_SCALE_STEPS = 6
#: A change of the mission is a different survey: it is advised over the current and the box shrunk
#: together on the declared mission only when it certifies the declared ones, or more than this
#: many times the joint scale.
MISSION_OVER_TOGETHER = 2.0
#: A current (or a box scale) that certifies only below this share of the declared one leaves the
#: survey in a different sea: on a mission that turns, a change of the mission that certifies the
#: declared current and box is then looked for as well, and advised first.
WEAK_WORLD = 0.5
#: Bisection steps of the advised sample time between the default period :data:`~auv_hinf.guidance.simulation.STEP`
#: and a longer declared one, geometric: 2^-6 of the ratio's logarithm (6 % between 0.1 s and 5 s).
PERIOD_STEPS = 6
#: Largest heading bandwidth times sample time tried: the sampled heading loop keeps a tenth of a
#: period per radian of its bandwidth's phase (0.4 rad at 10 Hz and 4 rad/s).
MAX_BANDWIDTH_STEP = 0.4


def cascade_problem(cfg: FormationConfig, point: DesignPoint) -> CascadeProblem | str:
    """The cascade's certificate problem of ``cfg``, or why it is not evaluated.

    Parameters
    ----------
    cfg : FormationConfig
        A configuration with ``[guidance]`` and an underactuated ``[actuators]``.
    point : DesignPoint
        Its design point (the mission, its tube and the offsets).
    """
    g, act, impl = cfg.guidance, cfg.actuators, cfg.implementation
    if g is None or not isinstance(act, RudderActuation):
        return "[guidance] needs an underactuated [actuators] table: a propeller and a rudder"
    unsupported = _unsupported(cfg)
    if unsupported:
        return unsupported[0][0]
    tube = point.tube
    speed_lo = tube.speed[:, 0]
    if float(speed_lo.min()) <= 0.0:
        return SLOT_STOPS
    jerk, _ = mission_jerks(point.mission, point.offsets, cfg.frame)
    accel = float(tube.accel.max())
    # in the inertial frame every slot moves with the centre: a centre path of constant speed by
    # construction (the line, the circle, the lawn-mower) gives U' = U'' = 0
    constant_path = isinstance(point.mission, CONSTANT_SPEED_PATHS)
    constant = cfg.frame == "inertial" and constant_path
    # two sound bounds of each: the tube's (|U'| <= |p_d''|; the course's rate and acceleration from
    # |p_d''| and the jerk) and the slots' closed forms (slot_bounds); both hold, the smaller is used
    slots = slot_bounds(point.mission, point.offsets, cfg.frame, constant_speed=constant_path)
    speed_rate = min(0.0 if constant else accel, slots.speed_rate)
    turn = min(float((tube.accel / speed_lo).max()), slots.turn_rate)
    turn_accel = min(float((jerk / speed_lo + 2.0 * tube.accel**2 / speed_lo**2).max()), slots.turn_accel)
    problem = CascadeProblem(
        guidance=g,
        plant=deployed_plant(cfg),
        act=act,
        speed=(float(speed_lo.min()), float(tube.speed[:, 1].max())),
        speed_rate=speed_rate,
        turn_rate=turn,
        turn_accel=turn_accel,
        speed_jerk=0.0 if constant else float(jerk) + turn * accel,
        sample_time=cascade_period(impl),
        delay=impl.delay,
        noise=impl.noise,
    )
    return _with(cfg, problem)


def _slots_at_start(cfg: FormationConfig) -> SlotMotion:
    """Every slot at ``t = 0``."""
    s = slot_motion(raw_fleet(cfg), np.array([0.0]))
    return SlotMotion(p=s.p[0], v=s.v[0], a=s.a[0])


def configured_start(cfg: FormationConfig, problem: CascadeProblem, slot: SlotMotion | None = None) -> np.ndarray:
    """Bounds of the cascade's states at ``t = 0`` for the configured start, in any current up to the bound.

    Without ``[simulation] initial`` every vehicle starts on its slot heading into the current it
    runs in (as ``simulate`` and ``campaign`` start it); with it, the declared states in any
    current up to the bound.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    problem : CascadeProblem
        Its cascade problem (start not used).
    slot : SlotMotion or None
        Every slot at ``t = 0`` (computed from ``cfg`` when not given).
    """
    slot = _slots_at_start(cfg) if slot is None else slot
    if cfg.simulation.initial is None:
        return into_current_start(problem, slot)
    return start_states(problem, np.asarray(cfg.simulation.initial, dtype=float), slot, None)


@dataclass(frozen=True)
class MissionAnswer:
    """A change of the mission (with, if needed, a smaller current and box) at which the cascade is certified.

    Attributes
    ----------
    what : {"turns", "speed", "both"}
        Wider turns, a slower mission, or the widest turns at a slower speed.
    settings : tuple of Setting
        Every value to write: the mission's, then the current and the box when ``scale < 1``.
    scale : float
        The joint scale of the declared current and box in the answer (1: as declared).
    position_bound : float
        The certified bound of every vehicle's distance to its slot in the rewritten configuration (m).
    """

    what: str
    settings: tuple[Setting, ...]
    scale: float
    position_bound: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary: ``{change, settings: [{table, key, value}], scale, position_bound}``."""
        return {
            "change": self.what,
            "settings": [x.to_dict() for x in self.settings],
            "scale": self.scale,
            "position_bound": self.position_bound,
        }


@dataclass(frozen=True)
class GuidanceSummary:
    """The guidance part's result for one configuration.

    Attributes
    ----------
    problem : CascadeProblem or None
        The certificate problem (``None``: not evaluated).
    certificate : CascadeCertificate or None
        Its certificate.
    reason : str
        Why it is not evaluated or does not hold (empty when it holds).
    current_speed, box_scale : float or None
        When it does not hold: the largest current (m/s, with the declared box) and the largest
        scale of the declared box (with the declared current) that certify; ``None``: none found.
    gains : GuidanceConfig or None
        When it does not hold: the first gains of :data:`GAIN_CANDIDATES` that certify the
        declared box and current (``None``: none does).
    mission_binds : bool
        Nothing of the above certifies, and neither does the nominal plant in no current: the
        mission (its turns, its slots' speeds) and the gains bind, not the box or the current.
    mission : MissionAnswer or None
        When nothing of the above certifies: a change of the mission that does
        (:func:`mission_answer`). Also when only a current or a box scale below
        :data:`WEAK_WORLD` of the declared certifies a mission that turns: a change of the mission
        that certifies the declared current and box, if there is one.
    together : float or None
        When neither the current nor the box alone certifies, both are declared and the nominal
        plant in still water certifies the declared mission: the largest joint scale of the two
        that certifies it (0: none found).
    start_bound : float or None
        When ``[simulation] initial`` is declared and the default start (every vehicle on its slot,
        heading into the current) certifies the declared box and current: its certified distance
        to the slot (m).
    supported : tuple of Setting
        When the cascade is not evaluated (plain LOS, a varying delay, a varying current): the
        settings that make it one this version certifies (:func:`supported_settings`), when the
        configuration re-run with them certifies; empty otherwise.
    supported_bound : float or None
        The certified distance to the slot (m) of that re-run.
    lag_scale : float or None
        When it does not hold, no gains of :data:`GAIN_CANDIDATES` certify and an ``[implementation]``
        delay or noise is declared: the largest scale of the delay and the noise together that
        certifies the declared box and current (``None``: none found, or none declared).
    sample_time : float or None
        When none of the above certifies and the declared sample time is longer than the default
        period :data:`~auv_hinf.guidance.simulation.STEP`: the longest sample time (s) that certifies
        the declared box and current with the declared delay and noise (``None``: not even the default).
    envelope : tuple of Setting
        When the cascade is certified but its certified motion leaves the declared ``[envelope]``
        (:func:`envelope_gap`): the envelope's ranges widened to hold it.
    spread : tuple of Setting
        When the cascade is certified but its bound leaves two vehicles closer than ``[formation]
        min_separation``: a spread of the formation re-certified as written (:func:`_spread`; the
        separation part answers with it); empty otherwise.
    world_envelope : tuple of Setting
        When the answer is a smaller current or box and its certified motion leaves the declared
        ``[envelope]`` (a mission slower than the envelope's surge range, once the current no longer
        hides it): the envelope's ranges widened to hold it, written with the answer
        (:func:`_world_envelope`); empty otherwise.
    supported_then : str
        When the change to what this version certifies does not certify alone: the answer of the
        changed configuration, in words (:attr:`supported` then holds both; :func:`_then`).
    everything : float or None
        When a delay or noise is declared and neither the answers above nor a change of the mission
        certify: the largest scale of every declared effect together (delay, noise, current, box)
        that certifies, its values confirmed as written (0: none; :func:`_everything_scale`).
    """

    problem: CascadeProblem | None
    certificate: CascadeCertificate | None
    reason: str
    current_speed: float | None = None
    box_scale: float | None = None
    gains: GuidanceConfig | None = None
    mission_binds: bool = False
    mission: MissionAnswer | None = None
    together: float | None = None
    start_bound: float | None = None
    supported: tuple[Setting, ...] = ()
    supported_bound: float | None = None
    lag_scale: float | None = None
    envelope: tuple[Setting, ...] = ()
    sample_time: float | None = None
    spread: tuple[Setting, ...] = ()
    world_envelope: tuple[Setting, ...] = ()
    everything: float | None = None
    supported_then: str = ""

    @property
    def holds(self) -> bool:
        """The cascade is certified."""
        return self.certificate is not None and self.certificate.holds


def _with(
    cfg: FormationConfig, problem: CascadeProblem, *, current: float | None = None, scale: float | None = None
) -> CascadeProblem:
    """``problem`` with another current bound (m/s) or its box scaled, and the configured start's bounds in it."""
    pl = problem.plant
    box = pl.box if scale is None else pl.box.scaled(scale)
    other = replace(problem, plant=Plant(pl.model, box, pl.current if current is None else current, pl.current_rate))
    slot = _slots_at_start(cfg)
    start = tuple(float(x) for x in configured_start(cfg, other, slot))
    return replace(other, start=start, start_turn=float(np.abs(slot.course_rate).max(initial=0.0)))


def _reduced(cfg: FormationConfig) -> FormationConfig:
    """``cfg`` without what the cascade's certificate and its answers do not read: the name, and the
    ``[simulation]`` table but its ``initial`` states (a run's horizon, plant, current and seed)."""
    return replace(cfg, name="guidance", simulation=SimulationConfig(initial=cfg.simulation.initial))


def guidance_certificate(cfg: FormationConfig) -> GuidanceSummary:
    """The cascade's certificate of ``cfg`` alone, without the answers of a refusal (what a run is judged by).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (with ``[guidance]``).
    """
    return _certificate(_reduced(cfg))


def guidance_summary(cfg: FormationConfig) -> GuidanceSummary:
    """The cascade's certificate of ``cfg`` and, when it does not hold, what would certify.

    Each is computed once for every configuration that differs only in what it does not read
    (:func:`_reduced`).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (with ``[guidance]``).
    """
    return _summary(_reduced(cfg))


@functools.lru_cache(maxsize=32)
def _certificate(cfg: FormationConfig) -> GuidanceSummary:
    """:func:`guidance_certificate` of a reduced configuration."""
    problem = cascade_problem(cfg, design_point(cfg))
    if isinstance(problem, str):
        return GuidanceSummary(None, None, problem)
    cert = certify_cascade(problem)
    if cert.holds:
        left, widened = envelope_gap(cfg.envelope, cert)
        if left:
            why = f"the certified motion leaves the declared [envelope], where the vehicle model holds: {left}"
            return GuidanceSummary(problem, replace(cert, holds=False, reason=why), why, envelope=widened)
    return GuidanceSummary(problem, cert, "" if cert.holds else cert.reason)


#: The envelope's ranges the cascade's certified motion is checked against: the name in words and the unit.
ENVELOPE_WORDS = {"u": ("surge speed", "m/s"), "v": ("sway speed", "m/s"), "r": ("yaw rate", "rad/s")}


def envelope_gap(envelope: Envelope, cert: CascadeCertificate) -> tuple[str, tuple[Setting, ...]]:
    """What of ``cert``'s certified motion leaves ``envelope``, in words, and the ranges widened to hold it.

    The certificate bounds the surge speed through the water (a range), the sway speed and the yaw
    rate (magnitudes) of every vehicle for all time; the ``[envelope]`` declares where the vehicle
    model holds. Each widened range is rounded outwards to :data:`ADVICE_DIGITS` decimals. Empty
    words (and no settings) when the motion stays inside.

    Parameters
    ----------
    envelope : Envelope
        The declared ``[envelope]``.
    cert : CascadeCertificate
        A certificate that holds (its :attr:`~CascadeCertificate.actuation` and error box are set).
    """
    a, errors = cert.actuation, cert.errors
    assert a is not None and errors is not None
    sway = float(errors[STATES.index("sway")])
    motion = {"u": a.surge, "v": (-sway, sway), "r": (-a.yaw_rate, a.yaw_rate)}
    margins = envelope.box_margins(a.surge, sway, a.yaw_rate)
    words, widened = [], []
    for key, (lo, hi) in motion.items():
        if min(margins[f"{key}_min"], margins[f"{key}_max"]) >= 0.0:
            continue
        e_lo, e_hi = getattr(envelope, key)
        name, unit = ENVELOPE_WORDS[key]
        words.append(f"{name} in [{lo:.4g}, {hi:.4g}] {unit} against [envelope] {key} = [{e_lo:.4g}, {e_hi:.4g}]")
        widened.append(Setting("envelope", key, [_down(min(lo, e_lo)), _up(max(hi, e_hi))]))
    return "; ".join(words), tuple(widened)


@functools.lru_cache(maxsize=32)
def _summary(cfg: FormationConfig) -> GuidanceSummary:
    """:func:`guidance_summary` of a reduced configuration: its certificate, and the answers of a refusal."""
    base = _certificate(cfg)
    problem, cert = base.problem, base.certificate
    if problem is None or cert is None:
        if base.reason == SLOT_STOPS:
            return replace(base, mission=mission_answer(cfg))
        return _then(cfg, base, supported_settings(cfg))
    if cert.holds and not base.envelope:
        return replace(base, spread=_spread(cfg, cert))
    if base.envelope:
        return base  # a motion outside the envelope is answered by the envelope alone
    if cfg.simulation.initial is not None:  # with cells, as the re-run from the slots will certify it
        start_bound = _confirmed(cfg, (RESTART,), cells=True)
        if start_bound is not None:
            return replace(base, start_bound=start_bound)
    current = None
    if problem.plant.current > 0.0:
        current = largest_holding(
            lambda c: _kept_apart(cfg, _with(cfg, problem, current=c)), problem.plant.current, steps=ADVICE_STEPS
        )
    scale = None
    top = min(1.0, problem.plant.box.max_scale)  # the largest box scale an answer may advise
    if problem.plant.box.declared:
        scale = largest_holding(lambda s: _kept_apart(cfg, _with(cfg, problem, scale=s)), top, steps=ADVICE_STEPS)
    bounded = all(math.isfinite(x) for x in problem.start)  # no gains certify an unbounded start
    gains = _certifying_gains(problem) if bounded else None
    if gains is None:  # the smaller world is the answer: raised where cells of the box certify more
        if current is not None:
            current = _by_cells(
                cfg, problem, current, problem.plant.current, lambda c: _with(cfg, problem, current=c), _down
            )
        if scale is not None:
            scale = _by_cells(cfg, problem, scale, top, lambda s: _with(cfg, problem, scale=s), rounded_down)
    lag_scale = None
    if gains is None and bounded and _navigates(problem):
        lag_scale = _lag_scale(problem)
        if lag_scale and _confirmed(cfg, _navigation_settings(problem, lag_scale)) is None:
            lag_scale = None  # its rounded values, as written, are refused
    period = None
    if gains is None and bounded and not lag_scale and problem.sample_time > STEP:
        period = _longest_period(cfg, problem)
    if (
        gains is None
        and bounded
        and not lag_scale
        and period is None
        and _navigates(problem)
        and problem.sample_time > STEP
    ):
        # neither alone: the default period with a faster, more precise navigation
        both = _lag_scale(replace(problem, sample_time=STEP))
        written = (Setting("implementation", "sample_time", STEP), *_navigation_settings(problem, both or 0.0))
        if both and _confirmed(cfg, written) is not None:
            lag_scale, period = both, STEP
    bare = _navigation(_with(cfg, problem, current=0.0, scale=0.0), 0.0)
    binds = (
        current is None
        and scale is None
        and gains is None
        and not lag_scale
        and period is None
        and not certify_cascade(bare, cells=False).holds
    )
    world_answer = gains is None and not lag_scale and period is None  # the answer is a smaller current or box
    world_env: tuple[Setting, ...] = ()
    if world_answer and (current or scale):
        world_env = _world_envelope(cfg, problem, current, scale)
    if bool(current) or bool(scale) or gains is not None or bool(lag_scale) or period is not None or not bounded:
        return GuidanceSummary(
            problem,
            cert,
            cert.reason,
            current,
            scale,
            gains,
            binds,
            _world_keeping_mission(cfg, problem, current, scale) if world_answer else None,
            lag_scale=lag_scale or None,
            sample_time=period,
            world_envelope=world_env,
        )
    together = None
    if not binds and problem.plant.current > 0.0 and problem.plant.box.declared:
        together = _largest_scale(cfg, problem)
        if together > 0.0 and _confirmed(cfg, _world(cfg, problem, together)) is None:
            together = 0.0  # its rounded values, as written, are refused
    mission = mission_answer(cfg)
    everything = None
    if not together and mission is None and bounded and _navigates(problem):
        everything = _everything_scale(cfg, problem)
    last = GuidanceSummary(
        problem, cert, cert.reason, current, scale, gains, binds, mission, together, everything=everything
    )
    if cfg.simulation.initial is not None and not together and mission is None and not everything:
        # nothing certifies from the declared start, and the slots alone do not either: the start on the
        # slots with what certifies from there, confirmed together as written
        return _then(cfg, last, (RESTART,))
    return last


def _everything(cfg: FormationConfig, problem: CascadeProblem, scale: float) -> CascadeProblem:
    """``problem`` with its delay, noise, current and box all scaled by ``scale``."""
    return _navigation(_with(cfg, problem, current=problem.plant.current * scale, scale=scale), scale)


def _everything_settings(cfg: FormationConfig, problem: CascadeProblem, scale: float) -> tuple[Setting, ...]:
    """The declared delay, noise, current and box scaled by ``scale``, as settings rounded to the certified side."""
    return _navigation_settings(problem, scale) + _world(cfg, problem, scale)


def _everything_scale(cfg: FormationConfig, problem: CascadeProblem) -> float:
    """The largest scale in ``[0, 1)`` of every declared effect together (delay, noise, current, box) that certifies.

    The last answer, when neither the navigation alone, the current and box together, nor a change
    of the mission certifies: each of them needs the other shrunk too. A bisection of
    :data:`MISSION_SCALE_STEPS` steps from ``s = 0`` (exact, undelayed navigation on the nominal
    plant in still water, checked first); its values, as written, are certified once more, and 0
    is returned when they are refused.
    """

    def holds(x: float) -> bool:
        return _kept_apart(cfg, _everything(cfg, problem, x))

    if not holds(0.0):
        return 0.0
    scale = bisect(holds, 0.0, 1.0, steps=MISSION_SCALE_STEPS)[0]
    if scale <= 0.0 or _confirmed(cfg, _everything_settings(cfg, problem, scale)) is None:
        return 0.0
    return scale


def _then(cfg: FormationConfig, base: GuidanceSummary, switch: tuple[Setting, ...]) -> GuidanceSummary:
    """``base`` with the answer of ``cfg`` changed to what this version certifies.

    The changed configuration is certified and answered as its re-run does it (:func:`_summary`, with
    cells of the box and the current, :func:`_advice`). When it certifies, with a bound that keeps
    the vehicles apart, the switch alone is the answer (:attr:`GuidanceSummary.supported`); else the
    switch and that answer together, confirmed by a re-run as written (with the answer's words in
    :attr:`GuidanceSummary.supported_then`). ``base`` unchanged when there is no switch, or no answer of
    the changed configuration certifies.
    """
    changed = _changed(cfg, switch) if switch else None
    if changed is None or supported_settings(changed[0]):  # the switch must make it one this version evaluates
        return base
    answer = _summary(_reduced(changed[0]))
    cert = answer.certificate
    alone = _apart(changed[0], cert) if cert is not None and cert.holds and not answer.envelope else None
    if alone is not None:
        return replace(base, supported=switch, supported_bound=alone)
    settings, words = _advice(changed[0], answer)
    # the run's own settings are not an answer, but a start moved onto the slots is
    both = switch + tuple(x for x in settings if x.table != "simulation" or x == RESTART)
    bound = _confirmed(cfg, both, cells=True) if settings else None  # as its re-run certifies it
    if bound is None:
        return base
    return replace(base, supported=both, supported_bound=bound, supported_then=words)


def _world_envelope(
    cfg: FormationConfig, problem: CascadeProblem, current: float | None, scale: float | None
) -> tuple[Setting, ...]:
    """The ``[envelope]`` ranges a smaller current (or, without one, box) answer needs, as written with it.

    The answer is the current rounded down (:func:`_down`), or the box scaled by ``scale``; when the
    cascade's certified motion there leaves the declared envelope (:func:`envelope_gap`), its ranges
    widened to hold it are part of the answer, else a re-run refuses on the envelope. Empty when the
    motion stays inside, or when the answer with them is not confirmed by a re-run as written.
    """
    changed = _with(cfg, problem, current=_down(current)) if current else _with(cfg, problem, scale=scale)
    cert = certify_cascade(changed, cells=False)
    if not cert.holds:
        return ()
    wider = envelope_gap(cfg.envelope, cert)[1]
    if not wider:
        return ()
    answer = (
        (Setting("disturbance", "current_speed", _down(current)),)
        if current
        else tuple(x for x in _world(cfg, problem, scale or 0.0) if x.table == "uncertainty")
    )
    return wider if _confirmed(cfg, answer + wider) is not None else ()


def _world_keeping_mission(
    cfg: FormationConfig, problem: CascadeProblem, current: float | None, scale: float | None
) -> MissionAnswer | None:
    """A change of the mission that certifies the declared current and box, when only a weak world certifies.

    Looked for on a mission that turns when the largest current that certifies (or, with none,
    the largest box scale) is below :data:`WEAK_WORLD` of the declared (:func:`mission_answer`);
    ``None`` otherwise, or when no change certifies the declared world.
    """
    share = current / problem.plant.current if current else scale
    if not problem.turns or share is None or share >= WEAK_WORLD:
        return None
    m = mission_answer(cfg)
    return m if m is not None and m.scale >= 1.0 else None


def _lag_scale(problem: CascadeProblem) -> float | None:
    """The largest share of ``problem``'s declared delay and noise, scaled together, that certifies (a bisection)."""
    with tqdm(total=ADVICE_STEPS + 2, unit="certificate", desc="navigation", leave=False, delay=PROGRESS_DELAY) as bar:

        def navigates(s: float) -> bool:
            bar.update()
            return certify_cascade(_navigation(problem, s), cells=False).holds

        return largest_holding(navigates, 1.0, steps=ADVICE_STEPS)


def _longest_period(cfg: FormationConfig, problem: CascadeProblem) -> float | None:
    """The longest sample time (s) between :data:`~auv_hinf.guidance.simulation.STEP` and the declared one that
    certifies the declared box and current, with the declared delay and noise; ``None`` when the default
    period does not (a geometric bisection of :data:`PERIOD_STEPS` steps, rounded down and confirmed as written)."""

    def holds(h: float) -> bool:
        return certify_cascade(replace(problem, sample_time=h), cells=False).holds

    if not holds(STEP):
        return None
    h = _down(bisect(holds, STEP, problem.sample_time, steps=PERIOD_STEPS, geometric=True)[0])
    return h if _confirmed(cfg, (Setting("implementation", "sample_time", h),)) is not None else None


def _navigates(problem: CascadeProblem) -> bool:
    """``problem`` declares a delay or measurement noise."""
    return problem.delay > 0.0 or not problem.noise.exact


def _navigation(problem: CascadeProblem, scale: float) -> CascadeProblem:
    """``problem`` with its delay and every noise bound scaled by ``scale`` (0: exact, undelayed navigation)."""
    return replace(problem, delay=problem.delay * scale, noise=problem.noise.scaled(scale))


def _navigation_settings(problem: CascadeProblem, scale: float) -> tuple[Setting, ...]:
    """The declared delay and noise bounds scaled by ``scale``, as settings rounded down (the certified side).

    To significant digits (:func:`~auv_hinf.composed.advice.rounded_down`), not decimals: a heading
    noise of 0.01 rad at 0.00879 of the declared is 8.79e-5 rad, which four decimals wrote as 0 (exact
    measurements, which no navigation gives).
    """
    out: list[Setting] = []
    if problem.delay > 0.0:
        out.append(Setting("implementation", "delay", _down_digits(problem.delay * scale)))
    for key, value in problem.noise.to_dict().items():
        if value > 0.0:
            out.append(Setting("implementation.noise", key, _down_digits(value * scale)))
    return tuple(out)


def _down_digits(x: float) -> float:
    """``x`` rounded down to three significant digits, written as that decimal (0.00439, not 0.004390000000000001).

    The advice is confirmed by a re-run with the values as written (:func:`_confirmed`).
    """
    return float(f"{rounded_down(x):.3g}")


def _navigation_words(figures: Mapping[str, Any]) -> str:
    """``", delay d s, noise <= ..."`` of the figures' delay and noise (empty when exact and undelayed)."""
    delay, noise = figures.get("delay") or 0.0, figures.get("noise") or {}
    out = f", delay {delay:.4g} s" if delay > 0.0 else ""
    if any(v > 0.0 for v in noise.values()):
        out += (
            f", noise <= {noise['position']:.3g} m, {noise['velocity']:.3g} m/s, {noise['heading']:.3g} rad, "
            f"{noise['yaw_rate']:.3g} rad/s"
        )
    return out


def _changed(cfg: FormationConfig, settings: tuple[Setting, ...]) -> tuple[FormationConfig, CascadeProblem] | None:
    """``cfg`` rewritten with ``settings`` and its cascade problem (``None``: not a valid or evaluable one)."""
    try:
        out = with_settings(cfg, [(x.table, x.key, x.value) for x in settings])
    except ConfigError:
        return None
    problem = cascade_problem(out, design_point(out))
    return None if isinstance(problem, str) else (out, problem)


def _holds(problem: CascadeProblem) -> bool:
    """The whole box's certificate holds (what holds whole also holds with cells)."""
    return certify_cascade(problem, cells=False).holds


def _world(cfg: FormationConfig, problem: CascadeProblem, scale: float) -> tuple[Setting, ...]:
    """The declared current and box scaled by ``scale``, as settings rounded towards the certified side."""
    out: list[Setting] = []
    if problem.plant.current > 0.0:
        out.append(Setting("disturbance", "current_speed", _down(problem.plant.current * scale)))
    if problem.plant.box.declared:
        scaled = problem.plant.box.scaled(scale)
        declared = {name for name, _ in cfg.uncertainty.box} & set(problem.plant.box.moving())
        out += [
            Setting("uncertainty", name, [_up(scaled.lo[k]), _down(scaled.hi[k])])
            for k, name in enumerate(PARAMETERS)
            if name in declared
        ]
    return tuple(out)


def _largest_scale(cfg: FormationConfig, problem: CascadeProblem) -> float:
    """The largest joint scale in ``[0, 1)`` of ``problem``'s current and box that certifies (0: none).

    A bisection of :data:`MISSION_SCALE_STEPS` steps from ``s = 0``, the nominal plant in still
    water (checked first); the declared world, ``s = 1``, is known to be refused.
    """

    def holds(x: float) -> bool:
        return _holds(_with(cfg, problem, current=problem.plant.current * x, scale=x))

    if not holds(0.0):
        return 0.0
    return bisect(holds, 0.0, 1.0, steps=MISSION_SCALE_STEPS)[0]


def mission_answer(cfg: FormationConfig) -> MissionAnswer | None:
    """The mildest change of the mission that certifies the declared box and current, else a scaled one.

    The changes (:func:`~auv_hinf.certificate.mission_advice.mission_changes`) come in kinds,
    each a ladder from mild to gentle: wider turns, a slower mission, and both. Each change is
    certified on the rewritten configuration as a re-run builds it. The gentlest change of a kind
    is tried first; when it certifies the declared box and current, its milder ones are tried in
    order and the first that certifies is the answer (coverage is not proven monotone along a
    ladder, so a refused gentlest change ends its kind). When no kind certifies them, the answer is
    the gentlest change of the first kind (wider turns before a slower mission, before both) with
    the largest joint scale of the current and the box that certifies it, when there is one
    (:func:`_largest_scale`), with the declared gains or the candidates of :data:`GAIN_CANDIDATES`
    that certify the largest scale (the declared ones on a tie). That answer, rounded towards the
    certified side, is certified once more as written, and dropped if it is not.

    Parameters
    ----------
    cfg : FormationConfig
        A configuration whose cascade is refused and whose declared current, box and gains, shrunk
        or changed alone, do not certify.
    """
    ladders: dict[str, list[tuple[Setting, ...]]] = {}
    for what, settings in mission_changes(cfg):
        ladders.setdefault(what, []).append(settings)
    gentlest: list[tuple[str, tuple[Setting, ...], FormationConfig, CascadeProblem]] = []
    with tqdm(total=len(ladders), unit="kind", desc="mission changes", leave=False, delay=PROGRESS_DELAY) as bar:
        for what, ladder in ladders.items():
            bar.update(1)
            changed = _changed(cfg, ladder[-1])
            if changed is None:
                continue
            gentlest.append((what, ladder[-1], *changed))
            if not _holds(changed[1]):
                continue
            for settings in ladder:  # mildest first; the gentlest holds, so one does
                milder = changed if settings is ladder[-1] else _changed(cfg, settings)
                if milder is None:
                    continue
                cert = certify_cascade(milder[1], cells=False)  # what holds whole holds with cells
                bound = _apart(milder[0], cert)
                if bound is not None:
                    # a slower mission may move slower than the declared envelope allows: its range comes along
                    wider = envelope_gap(milder[0].envelope, cert)[1]
                    return MissionAnswer(what, settings + wider, 1.0, bound)
    for what, settings, new_cfg, problem in gentlest:  # the first kind whose gentlest change certifies some
        # the declared gains and the candidates: the ones that certify the largest share of the world
        tried: list[tuple[GuidanceConfig, tuple[Setting, ...]]] = [(problem.guidance, ())]
        tried += [(g, _gain_settings(g, problem.guidance)) for g in _gain_variants(problem)]
        scored = [
            (_largest_scale(new_cfg, replace(problem, guidance=g)), k, gains) for k, (g, gains) in enumerate(tried)
        ]
        scale, _, gains = max(scored, key=lambda x: (x[0], -x[1]))
        if scale > 0.0:
            written = settings + gains + _world(new_cfg, problem, scale)
            got = _rerun(cfg, written)
            if got is None:
                return None
            bound, wider = got
            return MissionAnswer(what, written + wider, scale, bound)
    return None


def _unsupported(cfg: FormationConfig) -> list[tuple[str, tuple[Setting, ...]]]:
    """What of ``cfg`` this version does not certify: each reason, with the settings that remove it."""
    g, impl = cfg.guidance, cfg.implementation
    out: list[tuple[str, tuple[Setting, ...]]] = []
    if g is not None and g.sigma <= 0.0:
        out.append(
            (
                "plain LOS has no certificate in this version (its offset in a current is in closed form): "
                'use kind = "ilos"',
                (Setting("guidance", "kind", "ilos"),),
            )
        )
    if impl.varying_delay and impl.delay > 0.0:  # a delay varying within [0, 0] is no delay
        out.append(
            (
                "the cascade is certified with a fixed [implementation] delay in this version: "
                "set [implementation] varying_delay = false (the delay's bound, every sample)",
                (Setting("implementation", "varying_delay", False),),
            )
        )
    h = cascade_period(impl)
    if in_flight(h, impl.delay) > MAX_DELAY_SAMPLES:
        out.append(
            (
                f"the delay is {in_flight(h, impl.delay)} sample times, and the cascade's certificate analyses at "
                f"most {MAX_DELAY_SAMPLES} measurements in flight: declare [implementation] delay <= "
                f"{MAX_DELAY_SAMPLES * h:.4g} s",
                (Setting("implementation", "delay", MAX_DELAY_SAMPLES * h),),
            )
        )
    if cfg.disturbance.current_rate:
        out.append(
            (
                "the cascade is certified in a constant current (the 3-DOF model's water-relative velocities); "
                "remove [disturbance] current_rate",
                (Setting("disturbance", "current_rate", None),),
            )
        )
    return out


def supported_settings(cfg: FormationConfig) -> tuple[Setting, ...]:
    """The settings that turn ``cfg``'s cascade into one this version certifies (empty: nothing to change).

    Integral LOS for plain LOS, a fixed delay for a varying one, a constant current
    for a varying one: the settings of every reason :func:`cascade_problem` gives for not
    evaluating it.

    Parameters
    ----------
    cfg : FormationConfig
        A configuration with ``[guidance]``.
    """
    return tuple(x for _, settings in _unsupported(cfg) for x in settings)


def _rerun(
    cfg: FormationConfig, settings: tuple[Setting, ...], cells: bool = False
) -> tuple[float, tuple[Setting, ...]] | None:
    """The certified distance to the slot (m) of ``cfg`` rewritten with ``settings``, and the ``[envelope]``
    ranges widened to hold its certified motion (empty when it stays inside); ``None`` if refused (or if
    that distance leaves the vehicles closer than ``[formation] min_separation``, :func:`_separated`).
    The whole box is certified at once, or with ``cells`` as a re-run does (cells of the box and of the
    current when the whole is refused: one certificate a cell, so only for a single answer)."""
    rerun = _changed(cfg, settings)
    if rerun is None:
        return None
    cert = certify_cascade(rerun[1], cells=cells)
    bound = _apart(rerun[0], cert)
    if bound is None:
        return None
    return bound, envelope_gap(rerun[0].envelope, cert)[1]


def _confirmed(cfg: FormationConfig, settings: tuple[Setting, ...], cells: bool = False) -> float | None:
    """The certified distance to the slot (m) of ``cfg`` rewritten with ``settings``; ``None`` if refused, if
    that distance leaves the vehicles closer than ``[formation] min_separation``, or if the certified
    motion leaves the declared ``[envelope]`` (:func:`_rerun`, with ``cells`` as there)."""
    got = _rerun(cfg, settings, cells)
    return None if got is None or got[1] else got[0]


def fleet_refusal(cfg: FormationConfig, summary: GuidanceSummary | None = None) -> str:
    """Why a ``[guidance]`` fleet is not certified (empty when it is): its cascade, or the separation it leaves.

    What ``simulate`` and ``campaign`` hold a run to, as ``certify`` does: the cascade's certificate,
    and its bound of every vehicle's distance to its slot keeping every pair ``[formation]
    min_separation`` apart (the separation part's test, :func:`_separated`).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (with ``[guidance]``).
    summary : GuidanceSummary or None
        Its :func:`guidance_certificate` (computed when not given).
    """
    summary = guidance_certificate(cfg) if summary is None else summary
    if summary.certificate is None or not summary.certificate.holds:
        return "the guidance cascade is not certified" + (f": {summary.reason}" if summary.reason else "")
    if _apart(cfg, summary.certificate) is None:
        bound = summary.certificate.position_bound
        return (
            f"each vehicle is certified within {bound or math.inf:.4g} m of its slot, which leaves a pair of vehicles "
            f"closer than [formation] min_separation = {cfg.min_separation:g} m (certify names the pair and the "
            "spread of the formation that keeps them apart)"
        )
    return ""


#: Most spreads of a formation :func:`_spread` re-certifies: in the path frame the bound grows with the
#: spread (the outer slots are faster in the turns), and each try takes the last re-run's bound.
SPREAD_TRIES = 4


def _spread(cfg: FormationConfig, cert: CascadeCertificate) -> tuple[Setting, ...]:
    """A spread of ``cfg``'s formation whose re-run keeps every pair ``min_separation`` apart (empty: the
    certified bound already does, or no spread of :data:`SPREAD_TRIES` does).

    The spread is the separation part's (:func:`~auv_hinf.certificate.parts.separation.spread_factor`)
    for the last bound, and each is certified as written, as :func:`_rerun` certifies an answer.
    """
    bound = cert.position_bound
    if bound is None or _separated(cfg, bound):
        return ()
    point = design_point(cfg)
    for _ in range(SPREAD_TRIES):
        settings = spread_settings(point, spread_factor(separation_with(point, bound)) * (1.0 + ADVICE_MARGIN))
        changed = _changed(cfg, settings) if settings else None
        if changed is None:
            return ()
        rerun = certify_cascade(changed[1], cells=False)  # the re-run as written, once (:func:`_rerun`'s test)
        if _apart(changed[0], rerun) is not None and not envelope_gap(changed[0].envelope, rerun)[1]:
            return settings
        again = rerun.position_bound if rerun.holds else None
        if again is None or again <= bound:  # refused, or not for its bound: a wider spread will not help
            return ()
        bound = again
    return ()


#: Larger values of an advised current or box scale tried with cells of the box (:func:`_by_cells`), each the
#: geometric middle of the last one certified and the declared one.
CELL_PROBES = 2
#: Most cells one probe of :func:`_by_cells` certifies (a re-run's budget is
#: :data:`~auv_hinf.cascade.certificate.MAX_CELLS`, 80): a probe that certifies takes a few (a review's line
#: of four REMUS-like vehicles: 2 of the current, 2 of the masses), one that is refused would spend the
#: whole budget (a review's refusal took 111 s, most of it in two refused probes).
PROBE_CELLS = 16


def _by_cells(
    cfg: FormationConfig,
    problem: CascadeProblem,
    found: float | None,
    declared: float,
    changed: Callable[[float], CascadeProblem],
    written: Callable[[float], float],
) -> float | None:
    """``found`` (the largest value that certifies the whole box at once), raised where cells of the box certify.

    The bisection of an advised current or box scale certifies the whole box at once, the cheap test;
    the re-run certifies with cells (:func:`~auv_hinf.cascade.certificate.certify_cascade`), which holds
    for more. Up to :data:`CELL_PROBES` values are tried, each the geometric middle of the last value that
    certified and the declared one, as written (``written`` rounds it to the certified side), and the
    last that certifies with cells and keeps ``[formation] min_separation`` is the answer; a probe that is
    refused ends the search (each costs at most :data:`PROBE_CELLS` cells; what certifies within them
    certifies within a re-run's larger budget, the search being the same).
    Without cells to cut (no box, and a mission that turns) ``found`` is the answer.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    problem : CascadeProblem
        Its cascade.
    found : float or None
        The bisection's answer (``None``: nothing certifies, then nothing is probed).
    declared : float
        The declared value (the top of the bisection).
    changed : callable
        The cascade with the value changed.
    written : callable
        The value as the answer writes it (rounded towards the certified side).
    """
    if not found or found >= declared or not (problem.plant.box.declared or current_cells_apply(problem)):
        return found
    best = found
    for _ in range(CELL_PROBES):
        value = written(math.sqrt(best * declared))
        if value <= best or _apart(cfg, certify_cascade(changed(value), budget=PROBE_CELLS)) is None:
            break
        best = value
    return best


def _kept_apart(cfg: FormationConfig, problem: CascadeProblem) -> bool:
    """``problem`` (``cfg``'s cascade with a smaller current or box) certifies, with a bound that keeps the
    vehicles ``[formation] min_separation`` apart (:func:`_separated`): both shrink with the current and the
    box, so the largest value that certifies is found by bisection."""
    return _apart(cfg, certify_cascade(problem, cells=False)) is not None


def _apart(cfg: FormationConfig, cert: CascadeCertificate) -> float | None:
    """``cert``'s certified distance to the slot (m) when it holds with a bound that keeps ``cfg``'s vehicles
    ``[formation] min_separation`` apart (:func:`_separated`); ``None`` otherwise."""
    bound = cert.position_bound if cert.holds else None
    return bound if bound is not None and _separated(cfg, bound) else None


def _separated(cfg: FormationConfig, bound: float) -> bool:
    """Vehicles each within ``bound`` (m) of their slots keep ``cfg``'s ``[formation] min_separation``
    (:func:`~auv_hinf.certificate.parts.separation.keeps_separation`)."""
    return keeps_separation(design_point(cfg), bound)


def _gain_variants(problem: CascadeProblem) -> list[GuidanceConfig]:
    """The gains of :data:`GAIN_CANDIDATES` (multiples of the declared ones) that the sample time allows
    (:data:`MAX_BANDWIDTH_STEP`), gentlest first."""
    g = problem.guidance
    out = []
    for bandwidth, lookahead in GAIN_CANDIDATES:
        # each multiple as the decimal an advice writes (1.5 x 2.4 is 3.6 rad/s, not 3.5999999999999996),
        # so that the gains certified are the gains written
        w = float(f"{g.heading_bandwidth * bandwidth:.6g}")
        if w * problem.sample_time <= MAX_BANDWIDTH_STEP:
            out.append(replace(g, heading_bandwidth=w, lookahead=float(f"{g.lookahead * lookahead:.6g}")))
    return out


#: The gains an answer may change, and their units.
GAIN_UNITS = {"heading_bandwidth": "rad/s", "lookahead": "m"}


def _gain_settings(gains: GuidanceConfig, declared: GuidanceConfig) -> tuple[Setting, ...]:
    """``gains``' heading bandwidth (rad/s) and lookahead (m) that differ from the ``declared`` ones, as settings."""
    return tuple(
        Setting("guidance", key, getattr(gains, key))
        for key in GAIN_UNITS
        if getattr(gains, key) != getattr(declared, key)
    )


def _certifying_gains(problem: CascadeProblem) -> GuidanceConfig | None:
    """The first of :data:`GAIN_CANDIDATES` whose certificate holds for ``problem``'s box and current.

    Each candidate is tried on the whole box first, then (when none holds so) with cells of the
    along-track current (a few loops each): a re-run with the gains certifies either way.
    """
    candidates = _gain_variants(problem)
    for cells in (False, True):
        for gains in candidates:
            if certify_cascade(replace(problem, guidance=gains), cells=cells, mass_cells=False).holds:
                return gains
    return None


def _down(x: float) -> float:
    """``x`` rounded down to :data:`ADVICE_DIGITS` decimals (an advised value never exceeds the certified one)."""
    scale = 10.0**ADVICE_DIGITS
    return math.floor(x * scale) / scale


def _up(x: float) -> float:
    """``x`` rounded up to :data:`ADVICE_DIGITS` decimals."""
    scale = 10.0**ADVICE_DIGITS
    return math.ceil(x * scale) / scale


def _mission_sentence(m: MissionAnswer) -> str:
    """``m``'s values, what they change and the certified distance to the slot, in words."""
    world = (
        "the current and the box as declared"
        if m.scale >= 1.0
        else f"the current and the box together at {m.scale:.3g} of the declared"
    )
    within = f"every vehicle within {upper(m.position_bound, 3)} m of its slot"
    gains = " with the heading loop's gains changed" if any(s.table == "guidance" for s in m.settings) else ""
    return f"{toml_line(m.settings)} certifies ({CHANGE_WORDS[m.what]}{gains}, {world}; {within})"


def _advice(cfg: FormationConfig, summary: GuidanceSummary) -> tuple[tuple[Setting, ...], str]:
    """The settings to re-run with, and their sentence (empty when none certifies).

    The start on the slots (when a declared start binds) and gains that certify the declared box
    and current come first (they leave the declared world as it is), then the largest current,
    then the largest box scale (each after a change of the mission that certifies the declared
    world, when it is below :data:`WEAK_WORLD` of the declared), then the current and the box
    together on the declared mission or a change of the mission (:data:`MISSION_OVER_TOGETHER`).
    Every advised value is rounded towards the certified side: a current down, a box's lower
    multipliers up and upper ones down.
    """
    problem = summary.problem
    if problem is None:
        if summary.supported_bound is not None and summary.supported_then:
            return summary.supported, (
                f"changed to what this version certifies, it is still refused, and answered: {summary.supported_then}; "
                f"both together ({toml_line(summary.supported)}) certify: every vehicle within "
                f"{upper(summary.supported_bound, 3)} m of its slot"
            )
        if summary.supported_bound is not None:
            return summary.supported, (
                f"changed to what this version certifies ({toml_line(summary.supported)}), it is certified: every "
                f"vehicle within {upper(summary.supported_bound, 3)} m of its slot"
            )
        m = summary.mission
        return ((), "") if m is None else (m.settings, _mission_sentence(m))
    if summary.envelope:
        return summary.envelope, (
            f"if the model holds there, widen the envelope: {toml_line(summary.envelope)} certifies; "
            f"else {_envelope_remedy(cfg.envelope, summary.envelope)}"
        )
    if summary.start_bound is not None:
        disc = (
            " (a declared start is judged in every current up to [disturbance] current_speed: a heading that is the "
            "crab of one current is a heading error in the others, while the default start heads into whichever "
            "current the fleet meets)"
            if problem.plant.current > 0.0
            else ""
        )
        return (RESTART,), (
            f"the declared start binds{disc}: every vehicle started on its slot, heading into the current, "
            f"certifies ({RESTART.toml()}; every vehicle within {upper(summary.start_bound, 3)} m of its slot)"
        )
    if summary.supported_bound is not None and summary.supported[:1] == (RESTART,):
        return summary.supported, (
            f"nothing certifies from the declared start, and the start on the slots alone does not either: from "
            f"the slots it is answered: {summary.supported_then}; both together ({toml_line(summary.supported)}) "
            f"certify: every vehicle within {upper(summary.supported_bound, 3)} m of its slot"
        )
    if summary.gains is not None:
        settings: tuple[Setting, ...] = _gain_settings(summary.gains, problem.guidance)
        return settings, f"{toml_line(settings)} certifies the declared box and current"
    if summary.lag_scale is not None and summary.lag_scale > 0.0:
        settings = _navigation_settings(problem, summary.lag_scale)
        if summary.sample_time is not None:  # neither alone certifies: both together
            period = Setting("implementation", "sample_time", summary.sample_time)
            return (period, *settings), (
                f"a shorter sample time and a faster, more precise navigation together certify the declared box and "
                f"current: {period.words()} with the delay and the noise at {summary.lag_scale:.3g} of the declared "
                f"({toml_line(settings)})"
            )
        return settings, (
            f"a faster, more precise navigation certifies the declared box and current: the delay and the noise "
            f"together at {summary.lag_scale:.3g} of the declared ({toml_line(settings)})"
        )
    if summary.sample_time is not None:
        period = Setting("implementation", "sample_time", summary.sample_time)
        kept = " with the declared delay and noise" if _navigates(problem) else ""
        return (period,), f"a shorter sample time certifies the declared box and current{kept}: {period.words()}"
    m = summary.mission
    small: tuple[Setting, ...] = ()
    if summary.current_speed is not None and summary.current_speed > 0.0:
        small, words = (Setting("disturbance", "current_speed", _down(summary.current_speed)),), "a smaller current"
    elif summary.box_scale is not None and summary.box_scale > 0.0:
        small = tuple(x for x in _world(cfg, problem, summary.box_scale) if x.table == "uncertainty")
        words = f"the [uncertainty] box scaled by {summary.box_scale:.3g}"
    if small:
        if m is not None and m.scale >= 1.0:  # a weak world: the mission change that keeps the declared one first
            return m.settings, (
                f"on the declared mission only {words} certifies ({toml_line(small)}); keeping the declared current "
                f"and box, {_mission_sentence(m)}"
            )
        if summary.world_envelope:
            small += summary.world_envelope
            return small, (
                f"{words} certifies, with the [envelope] widened to hold the motion it leaves (if the model holds "
                f"there): {toml_line(small)}"
            )
        return small, f"{words} certifies: {toml_line(small)}"
    s0 = summary.together or 0.0
    if s0 > 0.0 and (m is None or (m.scale < 1.0 and m.scale <= MISSION_OVER_TOGETHER * s0)):
        world = _world(cfg, problem, s0)
        world += run_settings(cfg, world)  # the configured run kept inside, written with the answer
        other = (
            ""
            if m is None
            else f"; or, with a change of the mission, {toml_line(m.settings + run_settings(cfg, m.settings))}"
        )
        alone = (
            "with the declared box only still water certifies, and no smaller box alone does"
            if summary.current_speed == 0.0  # the bisection's lower end, still water, holds: nothing above it
            else "no smaller current or smaller box alone certifies"
        )
        return world, (
            f"{alone}: the current and the box together at {s0:.3g} of "
            f"the declared do, on the declared mission ({toml_line(world)}){other}"
        )
    if m is not None:
        lead = (
            "the mission binds (even the nominal plant in still water is refused)"
            if summary.mission_binds
            else f"no {_tried(problem, 'gains')} alone certify"
        )
        return m.settings, f"{lead}: {_mission_sentence(m)}"
    if summary.everything:
        settings = _everything_settings(cfg, problem, summary.everything)
        settings += run_settings(cfg, settings)  # the configured run kept inside, written with the answer
        return settings, (
            f"neither a faster, more precise navigation, the current and the box together, nor a change of the "
            f"mission certifies alone: every declared effect together at {summary.everything:.3g} of the declared "
            f"does ({toml_line(settings)})"
        )
    if summary.mission_binds:
        frame = " and the path-frame slots' speed changes" if problem.speed[1] > problem.speed[0] * (1.0 + 1e-9) else ""
        if problem.turn_rate > 0.0 or frame:
            return (), (
                f"no {_tried(problem, 'faster heading loop')} certifies it: the mission binds (its turns"
                f"{frame}; a straight line in the inertial frame certifies more easily, docs/derivations/guidance.md)"
            )
        start = "from the declared start" if cfg.simulation.initial is not None else "even from the slots"
        return (), f"no {_tried(problem, 'faster heading loop')} certifies it, {start}"
    return (), ""


def _envelope_remedy(envelope: Envelope, widened: tuple[Setting, ...]) -> str:
    """The change of the mission that keeps its motion in ``envelope``, in words.

    Surge below the envelope's range asks for a faster mission; surge above it, or sway and yaw rates
    beyond theirs (which grow with the speed and the turns), for a slower one.
    """
    slower = faster = False
    for x in widened:
        lo, hi = getattr(envelope, x.key)
        if x.key == "u" and x.value[0] < lo:
            faster = True
        if x.key != "u" or x.value[1] > hi:
            slower = True
    if faster and not slower:
        return "a faster mission (the surge speed through the water falls below the envelope)"
    if slower and not faster:
        return "slow the mission"
    return "a mission whose surge speed stays inside the envelope"


def _tried(problem: CascadeProblem, gains: str) -> str:
    """What a refusal's answers tried, in words: a smaller current or box only when one is declared, then ``gains``."""
    tried = [
        *(["smaller current"] if problem.plant.current > 0.0 else []),
        *(["smaller box"] if problem.plant.box.declared else []),
        gains,
    ]
    return ", ".join(tried[:-1]) + f" or {tried[-1]}" if len(tried) > 1 else tried[0]


def guidance_figures(cfg: FormationConfig, summary: GuidanceSummary) -> dict[str, Any]:
    """The ``guidance`` object of ``certify --json`` (SI units).

    Keys: the ``[guidance]`` gains, ``certified``, ``error_bounds{along_track, cross_track,
    heading}`` (m, m, rad), ``certified_peak{force_x, rudder}`` (N, rad), ``limits``, ``states``
    (the whole certified box), ``current_speed`` (m/s, the current bound it is judged in),
    ``sample_time`` (s), ``start`` (the certified start's bounds),
    ``cells`` (the cells of the box certified one by one, 1 for the whole box at once),
    ``largest_certifiable{current_speed, box_scale, gains, together, everything, navigation_scale, sample_time,
    start_on_slots, mission, envelope, supported}`` and ``reason``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its ``[guidance]`` table).
    summary : GuidanceSummary
        The part's result.
    """
    assert cfg.guidance is not None
    cert, problem = summary.certificate, summary.problem
    body = {} if cert is None else cert.to_dict()
    act = cfg.actuators
    return {
        **cfg.guidance.to_dict(),
        "certified": summary.holds,
        "error_bounds": body.get("error_bounds"),
        "certified_peak": body.get("certified_peak"),
        "limits": act.to_dict() if isinstance(act, RudderActuation) else None,
        "states": body.get("states"),
        "sway_speed": body.get("sway_speed"),
        "surge_speed": body.get("surge_speed"),
        "current_speed": None if problem is None else problem.plant.current,
        "sample_time": None if problem is None else problem.sample_time,
        "delay": None if problem is None else problem.delay,
        "noise": None if problem is None else problem.noise.to_dict(),
        "start": None if problem is None else dict(zip(STATES, problem.start, strict=True)),
        "cells": body.get("cells"),
        "current_cells": body.get("current_cells"),
        "largest_certifiable": {
            "current_speed": summary.current_speed,
            "box_scale": summary.box_scale,
            "gains": None
            if summary.gains is None
            else {"heading_bandwidth": summary.gains.heading_bandwidth, "lookahead": summary.gains.lookahead},
            "together": summary.together,
            "everything": summary.everything,
            "navigation_scale": summary.lag_scale,
            "sample_time": summary.sample_time,
            "start_on_slots": None if summary.start_bound is None else {"position_bound": summary.start_bound},
            "mission": None if summary.mission is None else summary.mission.to_dict(),
            "envelope": [x.to_dict() for x in summary.envelope or summary.world_envelope] or None,
            "supported": None
            if summary.supported_bound is None
            else {
                "settings": [x.to_dict() for x in summary.supported],
                "position_bound": summary.supported_bound,
            },
        },
        "reason": summary.reason,
    }


@dataclass(frozen=True)
class GuidancePart:
    """The guidance cascade's certificate: it applies with ``[guidance]``.

    Attributes
    ----------
    name : str
        The registry name (:data:`PART`).
    key : str or None
        The JSON key of the figures (:data:`KEY`).
    """

    name: str = PART
    key: str | None = KEY

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The cascade's certificate (see the module docstring); does not apply without ``[guidance]``.

        Parameters
        ----------
        ctx : PartContext
            The design point and the earlier verdicts.
        """
        cfg = ctx.point.config
        if cfg.guidance is None:
            return Verdict(self.name, True, False)
        summary = guidance_summary(cfg)
        figures = guidance_figures(cfg, summary)
        cert = summary.certificate
        if summary.holds and cert is not None:
            return Verdict(self.name, True, True, (), figures, detail=summary, position_bound=cert.position_bound)
        settings, advice = _advice(cfg, summary)
        text = f"guidance: {summary.reason}" + (
            f"; {advice}" + (" (re-run with it)" if settings else "") if advice else ""
        )
        actuation = None if cert is None else cert.actuation
        channel, value, limit = "guidance", None, None
        if actuation is not None and isinstance(cfg.actuators, RudderActuation):
            if actuation.rudder > cfg.actuators.rudder_max:
                channel, value, limit = "rudder", actuation.rudder, cfg.actuators.rudder_max
            elif actuation.thrust > cfg.actuators.tau_x:
                channel, value, limit = "force_x", actuation.thrust, cfg.actuators.tau_x
        unsupported = summary.problem is None and summary.mission is None
        kind = "unsupported" if unsupported else "thrust" if channel != "guidance" else "not_covered"
        why = Reason(self.name, kind, text, channel=channel, value=value, limit=limit, settings=settings)
        return Verdict(self.name, False, True, (why,), figures, detail=summary)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The guidance kind, its lookahead, and its certified bounds or why there are none.

        Parameters
        ----------
        figures : Any
            The part's ``guidance`` object (``None``: no ``[guidance]``).
        record : mapping
            The whole certificate record.
        """
        f = figures
        if f is None:
            return []
        gain = f" sigma {f['integral_gain']:.4g} m/s," if f["kind"] == "ilos" else ""
        head = f"  guidance ({f['kind']})           lookahead {f['lookahead']:.4g} m,{gain}"
        b, pk, lim = f.get("error_bounds"), f.get("certified_peak"), f.get("limits")
        if not f.get("certified") or b is None or pk is None:
            return [f"{head} not certified: {f.get('reason', '')}"]
        cells, ranges = f.get("cells") or 1, f.get("current_cells") or 1
        by = ""
        if ranges > 1:
            by = f" (in {cells} cells: {ranges} ranges of the current along the track, each with its own nominal loop)"
        elif cells > 1:
            by = f" (the box in {cells} cells, each certified with its own nominal plant)"
        out = [
            f"{head} certified at h = {f['sample_time']:.4g} s{_navigation_words(f)}{by}",
            f"    errors <= along-track {upper(b['along_track'], 4)} m, cross-track {upper(b['cross_track'], 4)} m, "
            f"heading {upper(b['heading'], 4)} rad; sway <= {upper(f['sway_speed'], 4)} m/s",
        ]
        if lim is not None:
            out.append(
                f"    commands <= thrust {pk['force_x']:.4g} N of {lim['force_x']:.4g} N, "
                f"rudder {pk['rudder']:.4g} rad of {lim['rudder']:.4g} rad"
            )
        return out

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Nothing to say about a run of the fully actuated law (a guidance run is checked by :func:`covers_run`).

        Parameters
        ----------
        ctx : RunContext
            The run.
        """
        return None


def covers_run(
    cfg: FormationConfig,
    summary: GuidanceSummary,
    multipliers: np.ndarray | None,
    current: tuple[float, float],
    initial: np.ndarray | None,
) -> tuple[bool, str]:
    """Whether the cascade's certificate covers one run, and why (one line).

    The run is covered when the certificate holds and keeps the vehicles ``[formation]
    min_separation`` apart (:func:`fleet_refusal`), its plant is in the box (``multipliers``:
    the nine parameter multipliers, ``None`` for the nominal plant), its current within the bound,
    and its start within the certified start's bounds (``initial``: ``None`` for the default start,
    on the slots heading into the current).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    summary : GuidanceSummary
        Its guidance result.
    multipliers : ndarray or None
        The run's plant, as multipliers of the nominal parameters.
    current : tuple of float
        The run's current (m/s, inertial).
    initial : ndarray, shape (N, 6), or None
        The run's start.
    """
    problem, cert = summary.problem, summary.certificate
    refused = fleet_refusal(cfg, summary)
    if problem is None or cert is None or refused:
        return False, refused or "the guidance cascade is not certified"
    box = problem.plant.box
    if multipliers is not None:
        m = np.asarray(multipliers, dtype=float)
        if np.any(m < np.asarray(box.lo) * (1.0 - RUN_RTOL)) or np.any(m > np.asarray(box.hi) * (1.0 + RUN_RTOL)):
            return False, "the run's plant is outside the [uncertainty] box"
    speed = math.hypot(*current)
    if speed > problem.plant.current * (1.0 + RUN_RTOL):
        run, bound = apart(speed, problem.plant.current)
        return False, f"the run's current ({run} m/s) exceeds [disturbance] current_speed ({bound} m/s)"
    if initial is not None:
        start = start_states(problem, np.asarray(initial, dtype=float), _slots_at_start(cfg), np.asarray(current))
        if np.any(start > np.asarray(problem.start) * (1.0 + 1e-9) + 1e-12):
            return False, "the run's start is outside the certified start"
    return True, "the guidance certificate covers the run (plant in the box, current within the bound, certified start)"


def run_coverage(
    cfg: FormationConfig,
    report: Mapping[str, Any],
    multipliers: np.ndarray | None,
    current: tuple[float, float],
    initial: Any,
    six_dof: bool = False,
) -> dict[str, Any]:
    """The certificate's keys of a guidance run's report: coverage, the certified bounds, and whether the run kept them.

    ``certificate_covers_run`` (the certificate holds and covers the run's plant, current and
    start; a 6-DOF run is outside the 3-DOF model it covers), ``certified_errors``
    ``{along_track, cross_track, heading}`` (m, m, rad), ``certified_peak{force_x, rudder}``
    (N, rad), ``within_certified_bounds`` (every measured error and commanded peak at most its
    bound; ``None`` when the run is not covered) and ``coverage_reason``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    report : mapping
        The run's report (:meth:`~auv_hinf.guidance.simulation.GuidanceRun.report`).
    multipliers : ndarray or None
        The run's plant as multipliers of the nine coefficients (``None``: the nominal plant).
    current : tuple of float
        The run's current (m/s, inertial).
    initial : array_like or None
        The run's start, shape (N, 6) (``None``: on the slots heading into the current).
    six_dof : bool
        The run is on the 6-DOF model.
    """
    summary = guidance_certificate(cfg)
    covered, why = covers_run(cfg, summary, multipliers, current, initial)
    if six_dof:
        on_3dof = "it covers the same run on the 3-DOF model" if covered else f"on the 3-DOF model: {why}"
        covered, why = (
            False,
            f"not covered: this run is on the 6-DOF REMUS 100, the certificate is of the 3-DOF model ({on_3dof})",
        )
    cert = summary.certificate
    bounds = None if cert is None or not cert.holds else cert.error_bounds
    peak = (
        None
        if cert is None or not cert.holds or cert.actuation is None
        else {"force_x": cert.actuation.thrust, "rudder": cert.actuation.rudder}
    )
    within = None
    if covered and bounds is not None and peak is not None:
        measured, commanded = report["measured_errors"], report["commanded_peak"]
        within = all(measured[k] <= bounds[k] for k in bounds) and all(commanded[k] <= peak[k] for k in peak)
    return {
        "certificate_covers_run": covered,
        "certified_errors": bounds,
        "certified_peak": peak,
        "within_certified_bounds": within,
        "coverage_reason": why,
    }


def plant_multipliers(cfg: FormationConfig) -> np.ndarray:
    """The ``[simulation] plant`` multipliers in :data:`~auv_hinf.robust.box.PARAMETERS` order (1 where not given).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    """
    given = dict(cfg.simulation.plant)
    return np.array([float(given.get(name, 1.0)) for name in PARAMETERS])


__all__ = [
    "ADVICE_DIGITS",
    "ADVICE_STEPS",
    "CELL_PROBES",
    "CONSTANT_SPEED_PATHS",
    "GAIN_CANDIDATES",
    "GAIN_UNITS",
    "KEY",
    "MAX_BANDWIDTH_STEP",
    "PART",
    "SPREAD_TRIES",
    "WEAK_WORLD",
    "GuidancePart",
    "GuidanceSummary",
    "cascade_problem",
    "configured_start",
    "covers_run",
    "fleet_refusal",
    "guidance_certificate",
    "guidance_figures",
    "guidance_summary",
    "plant_multipliers",
    "run_coverage",
    "supported_settings",
]
