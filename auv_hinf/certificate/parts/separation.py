"""The separation part: a certified minimum distance between any two vehicles of the configured run.

The parts that bound the tracking errors (:data:`BOUNDING_PARTS`) each give, when they prove one, a
bound ``b_k`` of ``sup_t ||p_i(t) - p_d,i(t)||`` for every vehicle of the configured start, on the
system they model, against a reference ``p_d`` (the raw mission or the shaped start the closed
loop chose; :attr:`~auv_hinf.certificate.part.Verdict.position_bound`). Then for every pair and
every ``t >= 0``::

    ||p_i - p_j|| >= ||p_d,i - p_d,j|| - ||p_i - p_d,i|| - ||p_j - p_d,j|| >= D_k - 2 b_k

with ``D_k`` the closed-form lower bound of the desired distance of the pair
(:func:`~auv_hinf.mission.separation.slot_separation`). The certified minimum separation is
``min_k D_k - 2 max_k b_k`` (below every ``D_k - 2 b_k``), with the bound raised to the
integrator's numerical floor so that a simulated run is never measured below it.

Soundness: each part's bound holds for its own modelled system (the nominal plant, every plant
of the declared box and current, the sampled implementation); every part of
:data:`BOUNDING_PARTS` that applies must hold and prove a bound, and the most inclusive of them
covers the declared system, so the maximum is a bound of the declared system. A configured run
outside the declared system (its plant outside the box, its current above the bound) is bounded by
none of them: no separation is certified for it, and the refusal gives the ``[simulation]`` values
that bring it inside. When one of them applies and holds without a bound (the configured start
outside its certified set), the part does not hold: no separation is certified. When one of them
does not hold, or none applies (no closed loop), no separation is certified either, but that
part's reasons are the verdict: this part then does not apply (and adds no reason). The part
holds when the certified separation is at least ``[formation] min_separation``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.certificate.part import PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.parts.closed_loop import ON_SLOTS
from auv_hinf.certificate.parts.robust import run_outside
from auv_hinf.certificate.reason import Reason, Setting, upper
from auv_hinf.config.schema import MAX_COORDINATE
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.mission.separation import SlotSeparation, slot_separation
from auv_hinf.models.jacobi import regular_polygon
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR

#: The part's registry name.
PART = "separation"
#: The JSON key of its figures.
KEY = "formation"
#: The parts that bound the tracking errors: each one that applies must prove a position bound.
BOUNDING_PARTS = ("composed", "closed_loop", "robust", "implementation", "guidance")
#: Largest fleet for which a refusal suggests the scaled ``[formation] shape`` itself.
SHAPE_ADVICE_MAX_N = 12
#: The keys of ``[formation]`` that give the formation's geometry, exactly one of which is set.
FORMATION_FORMS = ("shape", "offsets", "polygon_radius")
#: Relative margin on the advised spread, above the rounding of the advised values to 4 digits.
ADVICE_MARGIN = 1e-3
#: Relative tolerance of the test that the formation is a regular polygon (then ``polygon_radius`` is advised).
POLYGON_RTOL = 1e-9


@dataclass(frozen=True)
class SeparationBound:
    """The certified separation of a design point, or why there is none.

    Attributes
    ----------
    required : float
        ``[formation] min_separation`` (m).
    slots : SlotSeparation
        The closed-form lower bound of the desired distance of the closest pair (m), over the
        references the bounds are about (the raw mission when no part proves a bound).
    position_bound : float or None
        ``max_k b_k`` raised to the numerical floor (m); ``None``: no bound is proved.
    parts : tuple of str
        The parts whose bounds enter it.
    missing : str or None
        Why no bound is proved (``None`` when one is).
    cause : Reason or None
        Why the configured run has no bound although every part that bounds the errors holds: its
        plant or current lies outside the declared box and bound
        (:func:`~auv_hinf.certificate.parts.robust.run_outside`), with the ``[simulation]`` values that
        bring it inside.
    decided_elsewhere : bool
        No bound because a part that bounds the errors does not hold, or none applies (the design
        gives no closed loop): that part's reasons are the verdict, and this part does not apply.
    """

    required: float
    slots: SlotSeparation
    position_bound: float | None
    parts: tuple[str, ...]
    missing: str | None = None
    decided_elsewhere: bool = False
    cause: Reason | None = None

    @property
    def certified(self) -> float | None:
        """The certified minimum distance between any two vehicles (m; ``None`` without a bound)."""
        return None if self.position_bound is None else self.slots.distance - 2.0 * self.position_bound

    @property
    def ok(self) -> bool:
        """A bound is proved and the certified separation reaches the required one."""
        return self.position_bound is not None and self.slots.keeps(self.position_bound, self.required)

    def to_dict(self) -> dict[str, Any]:
        """The ``formation`` object of ``auv-hinf certify --json`` (m; vehicles 0-based)."""
        return {
            "min_separation": self.required,
            "min_separation_certified": self.certified,
            "closest_pair": list(self.slots.pair),
            "slot_distance": self.slots.distance,
            "offset_distance": self.slots.slot_distance,
            "shaping": self.slots.shaping,
            "position_bound": self.position_bound,
            "bound_parts": list(self.parts),
            "certified": self.ok,
            "missing": self.missing,
        }


def separation_bound(point: DesignPoint, verdicts: Mapping[str, Verdict]) -> SeparationBound:
    """The certified separation of ``point`` from the position bounds of the earlier ``verdicts``.

    Parameters
    ----------
    point : DesignPoint
        The design point (offsets, frame, mission, required separation).
    verdicts : mapping of str to Verdict
        The earlier parts' verdicts, by name.
    """
    required = point.config.min_separation
    # every bound is about the declared system: a configured run outside it (a plant outside the box,
    # a current above the bound) is bounded by none of them
    outside = run_outside(point, PART, varying_current=True)
    applies = False
    for name in BOUNDING_PARTS:
        v = verdicts.get(name)
        if v is None or not v.applies:
            continue
        applies = True
        if not v.ok:
            return SeparationBound(required, slot_separation(point.fleet()), None, (), f"{name} does not hold", True)
        if v.position_bound is None and outside is None:
            why = f"the configured start is outside the certified set of {name}"
            return SeparationBound(required, slot_separation(point.fleet()), None, (), why)
    if applies and outside is not None:
        return SeparationBound(required, slot_separation(point.fleet()), None, (), outside.message, cause=outside)
    proving = [v for v in verdicts.values() if v.applies and v.ok and v.position_bound is not None]
    if not proving:
        why = "no part that bounds the tracking errors applies"
        return SeparationBound(required, slot_separation(point.fleet()), None, (), why, True)
    references: dict[int, FleetReference] = {}
    for v in proving:
        ref = point.fleet() if v.bound_reference is None else v.bound_reference
        references.setdefault(id(v.bound_reference), ref)
    slots = min((slot_separation(r) for r in references.values()), key=lambda s: s.distance)
    bound = max(NUMERICAL_FLOOR, *(float(v.position_bound or 0.0) for v in proving))
    return SeparationBound(required, slots, bound, tuple(v.part for v in proving))


def separation_with(point: DesignPoint, bound: float, reference: FleetReference | None = None) -> SeparationBound:
    """The separation of ``point``'s slots with every vehicle within ``bound`` (m) of its own.

    The bound is raised to the numerical floor as :func:`separation_bound` raises it.

    Parameters
    ----------
    point : DesignPoint
        The design point (its slots and required separation).
    bound : float
        The certified bound of every vehicle's distance to its slot (m).
    reference : FleetReference, optional
        The slots the bound is about, when not the mission's own (a shaped start's, which may bring
        two slots closer than the formation holds them).
    """
    slots = slot_separation(point.fleet() if reference is None else reference)
    return SeparationBound(point.config.min_separation, slots, max(NUMERICAL_FLOOR, bound), (PART,))


def keeps_separation(point: DesignPoint, bound: float) -> bool:
    """Vehicles each within ``bound`` (m) of their slots keep ``point``'s ``[formation] min_separation``.

    The separation part's own test (:func:`separation_with`): an answer that certifies the tracking
    errors but not this is not one that certifies when re-run.

    Parameters
    ----------
    point : DesignPoint
        The configuration's design, whose slots are held to ``[formation] min_separation``.
    bound : float
        How far (m) the certificate lets each vehicle be from its slot.
    """
    return separation_with(point, bound).ok


def separation_refusal(point: DesignPoint, bound: float, reference: FleetReference | None = None) -> str | None:
    """Why vehicles each within ``bound`` (m) of their slots break ``[formation] min_separation``, or ``None``.

    The refusal's words (:func:`refusal`) for a bound that a run or a campaign is checked against;
    ``None`` when the vehicles keep it.

    Parameters
    ----------
    point : DesignPoint
        The design point.
    bound : float
        The certified bound of every vehicle's distance to its slot (m).
    reference : FleetReference, optional
        The slots the bound is about (:func:`separation_with`).
    """
    sep = separation_with(point, bound, reference)
    return None if sep.ok else refusal(point, sep).message


def spread_factor(sep: SeparationBound) -> float:
    """How many times the formation must be spread for ``sep``'s bound to keep its closest pair apart.

    Every slot distance scales with the formation, so the closest pair's distance (its slots' less
    the shaped start's) is at least ``min_separation`` plus twice the bound once its slots are
    ``(min_separation + 2 bound + shaping) / slot distance`` times as far apart, as long as the
    bound does not grow with the spread (it does in the path frame, where wider slots are faster
    in the turns: re-certify).

    Parameters
    ----------
    sep : SeparationBound
        A separation with a position bound.
    """
    s, b = sep.slots, sep.position_bound or 0.0
    return (sep.required + 2.0 * b + s.shaping) / s.slot_distance


def spread_settings(point: DesignPoint, factor: float) -> tuple[Setting, ...]:
    """The ``[formation]`` value that spreads the formation by ``factor``, and the removal of the other forms.

    A regular polygon gets its ``polygon_radius``; any other formation its Jacobi ``shape`` (what
    ``init`` and a configuration's TOML form write). The table accepts exactly one of ``shape``,
    ``offsets`` and ``polygon_radius``, so the other two are removed (``None``): re-running with the
    settings works whichever form the file used. Empty when the spread formation would not be a
    valid configuration (too many vehicles for a written shape, or coordinates beyond its limit).

    Parameters
    ----------
    point : DesignPoint
        The design point (its offsets and its configuration's shape).
    factor : float
        How many times to spread the formation (> 0).
    """
    off = point.offsets
    n = off.shape[0]
    radius = float(np.hypot(off[:, 0], off[:, 1]).mean())
    value: float | list[list[float]]
    if np.allclose(off, regular_polygon(n, radius), rtol=0.0, atol=POLYGON_RTOL * max(radius, 1.0)):
        key, value = "polygon_radius", float(f"{radius * factor:.4g}")
        largest = abs(value)
    elif n <= SHAPE_ADVICE_MAX_N:
        # 7 digits: a pair's distance is a difference of the vectors, whose rounding it must not eat
        key, value = "shape", [[float(f"{x * factor:.7g}") for x in row] for row in point.config.shape]
        largest = max(abs(x) for row in value for x in row)
    else:
        return ()
    if largest > MAX_COORDINATE:  # a value the configuration refuses is no answer
        return ()
    others = [k for k in FORMATION_FORMS if k != key]
    return (Setting("formation", key, value), *(Setting("formation", k, None) for k in others))


def _bound_levers(point: DesignPoint) -> str:
    """What reduces the certified error bound, among what the configuration declares."""
    cfg = point.config
    levers = ["a start nearer the slots"] if cfg.simulation.initial is not None else []
    levers += ["a smaller [uncertainty] box"] if cfg.uncertainty.box else []
    levers += ["a smaller [disturbance] current_speed"] if (cfg.disturbance.current_speed or 0.0) > 0.0 else []
    impl = cfg.implementation
    levers += ["less [implementation.noise]"] if impl.sampled and not impl.noise.exact else []
    levers += ["a shorter [implementation] delay"] if impl.sampled and impl.delay > 0.0 else []
    return ", ".join(levers) or "other gains, or a slower mission"


def _written_factor(point: DesignPoint, settings: tuple[Setting, ...]) -> float:
    """The spread (times) that ``settings`` (of :func:`spread_settings`) write: the new size over the old."""
    first = settings[0]
    off = point.offsets
    if first.key == "polygon_radius":
        return float(first.value) / float(np.hypot(off[:, 0], off[:, 1]).mean())
    old = np.asarray(point.config.shape, dtype=float)
    return float(np.abs(np.asarray(first.value, dtype=float)).max() / np.abs(old).max())


def refusal(
    point: DesignPoint,
    sep: SeparationBound,
    spread: tuple[Setting, ...] | None = None,
) -> Reason:
    """The reason of a separation that is not certified: the pair, the distances, the bound, what to change.

    Parameters
    ----------
    point : DesignPoint
        The design point.
    sep : SeparationBound
        Its separation (not ``ok``).
    spread : tuple of Setting, optional
        A spread of the formation that the part bounding the errors has re-certified as written (the
        guidance part's, whose bound grows with the spread in the path frame); empty: none found.
    """
    s = sep.slots
    i, j = s.pair
    if sep.position_bound is None:
        # the run outside the declared system has its own values; else the start is what lies outside
        if sep.cause is not None:
            advice, settings = "", sep.cause.settings
        else:
            advice = "; start the fleet nearer its slots (without [simulation] initial it starts on them)"
            declared = point.config.simulation.initial is not None
            settings = (ON_SLOTS,) if declared else ()
        return Reason(
            PART,
            "not_covered",
            f"no certified minimum distance between the vehicles: no position-error bound for the configured run "
            f"({sep.missing}){advice}",
            channel="separation",
            limit=sep.required,
            settings=settings,
        )
    b, certified = sep.position_bound, s.distance - 2.0 * sep.position_bound
    shaped = f" less {s.shaping:.4g} m for the shaped start" if s.shaping > 0.0 else ""
    lead = (
        f"vehicles {i + 1} and {j + 1} are certified only {certified:.4g} m apart, below [formation] "
        f"min_separation = {sep.required:g} m: their slots are {s.slot_distance:.4g} m apart{shaped}"
    )
    error = f"each vehicle's position error is certified <= {upper(b, 4)} m"
    formation = slot_separation(point.fleet()).distance  # the slots' own closest approach, no shaped start
    if s.shaping > 0.0 and point.config.simulation.initial is not None and formation - 2.0 * b >= sep.required:
        # the shaped start from the declared positions is what brings them close: spreading the slots
        # moves the start's paths little (they still cross), starting on the slots does not
        settings = (ON_SLOTS,)
        message = (
            f"{lead} (the paths from the declared [simulation] initial positions to the slots pass that close), and "
            f"{error}; start the vehicles where their paths to the slots keep apart, e.g. on their slots (remove "
            f"[simulation] initial: the slots are {formation:.4g} m apart at the closest, {formation - 2.0 * b:.4g} m "
            f"with the bound)"
        )
    else:
        factor = spread_factor(sep)
        settings = spread_settings(point, factor * (1.0 + ADVICE_MARGIN))
        confirmed = bool(spread)
        if spread:  # re-certified as written by the part that bounds the errors
            settings, factor = spread, _written_factor(point, spread)
        words = (
            f"{settings[0].words()}, in place of " + " or ".join(x.key for x in settings[1:])
            if settings
            else "[formation] polygon_radius, offsets or shape"
        )
        message = (
            f"{lead}, and {error} (certified = slot distance - 2 x bound); spread the formation about {factor:.3g} "
            f"times ({words}), or reduce the certified error bound ({_bound_levers(point)})"
            + (
                " (re-run with it: the spread formation's bound is certified)"
                if confirmed
                else "; in the path frame wider slots are faster in the turns, which may raise the bound: re-run to "
                "check"
                if point.config.frame == "path"
                else ""
            )
        )
    return Reason(
        PART,
        "envelope",
        message,
        channel="separation",
        vehicle=i,
        value=certified,
        limit=sep.required,
        settings=settings,
    )


@dataclass(frozen=True)
class SeparationPart:
    """The smallest distance between any two vehicles of the configured run, held against ``min_separation``.

    It applies whenever the parts that bound the tracking errors hold (see the module docstring) and
    runs after them.

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
        """The separation of ``ctx.point`` from the earlier parts' position bounds (see :func:`separation_bound`).

        Parameters
        ----------
        ctx : PartContext
            The design point and the earlier verdicts.
        """
        sep = separation_bound(ctx.point, ctx.verdicts)
        if sep.decided_elsewhere:  # the failing part's reasons are the verdict
            return Verdict(self.name, True, False, (), sep.to_dict(), detail=sep)
        guided = ctx.detail("guidance")
        spread = getattr(guided, "spread", None)  # a guidance fleet's spread, re-certified as written
        reasons = () if sep.ok else (refusal(ctx.point, sep, spread),)
        return Verdict(self.name, sep.ok, True, reasons, sep.to_dict(), detail=sep)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The certified and required separation, the closest pair, its slot distance and the bound (m).

        Parameters
        ----------
        figures : Any
            The part's ``formation`` object (``None``: a record without the part).
        record : mapping
            The whole certificate record.
        """
        f = figures
        if f is None:
            return []
        i, j = f["closest_pair"]
        shaped = f" less {f['shaping']:.4g} m of shaped start" if f["shaping"] > 0.0 else ""
        slots = f"vehicles {i + 1}-{j + 1}: slots {f['offset_distance']:.4g} m apart{shaped}"
        if f["min_separation_certified"] is None:
            return [
                f"  min separation            not certified (required {f['min_separation']:g} m): "
                f"no position bound ({f['missing']}); {slots}"
            ]
        return [
            f"  min separation            {f['min_separation_certified']:.4g} m certified "
            f"(required {f['min_separation']:g} m; {slots}, position error <= {upper(f['position_bound'], 4)} m "
            f"from {', '.join(f['bound_parts'])})"
        ]

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """A condition on the run: the position bound of a certificate that covers it keeps every pair apart.

        With no covering certificate that bounds the position the run is not covered anyway, and
        nothing is added. A bound that leaves two vehicles closer than ``[formation]
        min_separation`` refuses the run and the gains, as ``certify`` refuses them (``simulate``
        and ``campaign`` then need ``--uncertified``); ``simulate`` reports the measured separation.

        Parameters
        ----------
        ctx : RunContext
            The run, and the earlier parts' checks of it.
        """
        covering = sorted(
            (
                (float(c.bounds["position"]), c.reference if isinstance(c.reference, FleetReference) else None)
                for c in ctx.checks.values()
                if c.applies and c.role == "certificate" and c.covers and c.bounds and "position" in c.bounds
            ),
            key=lambda pair: pair[0],
        )
        if not covering:
            return None
        # each covering certificate's bound is about the slots it tracks (a shaped start's slots may
        # pass closer to each other than the formation's): the run keeps the separation when one of
        # them shows it, and is refused with the tightest bound's words otherwise
        whys = [separation_refusal(ctx.point, bound, reference) for bound, reference in covering]
        why = None if None in whys else whys[0]
        if why is None:
            return RunCheck(self.name, "condition", True, True, "the certified separation holds")
        return RunCheck(self.name, "condition", True, False, why, (f"separation: {why}",), refuses_gains=why)


__all__ = [
    "ADVICE_MARGIN",
    "BOUNDING_PARTS",
    "FORMATION_FORMS",
    "KEY",
    "POLYGON_RTOL",
    "SHAPE_ADVICE_MAX_N",
    "SeparationBound",
    "SeparationPart",
    "keeps_separation",
    "refusal",
    "separation_bound",
    "separation_refusal",
    "separation_with",
    "spread_factor",
    "spread_settings",
]
