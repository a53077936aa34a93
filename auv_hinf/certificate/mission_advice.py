"""What certifies the deployed loop when no declared effect, shrunk, does: the design or the mission.

The composed part's advice (:mod:`auv_hinf.composed.advice`) shrinks the declared noise, delay,
sample time, current and box, the gains kept. When none of them certifies, even all together,
what binds is the design or the mission itself: the turns' rates and the speeds' drag leave the
sampled loops too little room. :func:`mission_advice` then tries, in this order, each change as
a user would make it and as a re-run computes it (the configuration rewritten with
:func:`~auv_hinf.config.settings.with_settings`, its gains designed again, its composed
certificate computed from its configured start):

1. gains designed for the deployed loop (``[design] robust = true, synthesis = "deployed"``),
   when the design is another;
2. wider turns: the lawn-mower's ``turn_radius`` and ``spacing`` (or the circle's ``radius``,
   or the sine's curvature) times :data:`TURN_FACTORS` in turn;
3. a slower mission: ``[reference] speed`` times :data:`SPEED_FACTORS` in turn;
4. both: the widest turns at each slower speed (:func:`mission_changes`).

Each answer is one at which the certificate was computed and covers, with its position bound, so
re-running with it certifies the composed part. Coverage is not proven monotone in these
settings: the first covered value of each ladder is reported, not the least change.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from tqdm.auto import tqdm

from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.certificate.reason import Setting, toml_line, upper
from auv_hinf.config.settings import FormationConfig
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant

#: Multipliers of the turn radius (and of the legs' spacing, which must hold two turns) tried in
#: turn: the turn rate falls as 1/radius, and the path frame's slot speeds spread as well.
TURN_FACTORS = (2.0, 4.0, 8.0)
#: Multipliers of the mission speed tried in turn (the drag, the Munk moment and the turn rates
#: fall with it).
SPEED_FACTORS = (0.5, 0.25)


@dataclass(frozen=True)
class MissionAdvice:
    """One change of the design or the mission at which the composed certificate covers.

    Attributes
    ----------
    what : str
        ``"design"``, ``"turns"`` or ``"speed"``.
    settings : tuple of Setting
        The TOML values to write.
    position_bound : float
        The certified position bound at them (m).
    """

    what: str
    settings: tuple[Setting, ...]
    position_bound: float

    def line(self) -> str:
        """The change, as the TOML values to write, and what it certifies."""
        return f"{toml_line(self.settings)} (certified |e| <= {upper(self.position_bound, 3)} m)"


def mission_changes(cfg: FormationConfig) -> list[tuple[str, tuple[Setting, ...]]]:
    """The changes of the mission a user can make, each kind from mild to gentle.

    ``"turns"``: the turns' radius of curvature times each of :data:`TURN_FACTORS` (the
    lawn-mower's ``turn_radius`` and ``spacing``, the circle's ``radius``, or the sine's ``omega``
    over the factor's square root: its curvature is ``A omega^2 / speed``). ``"speed"``:
    ``[reference] speed`` times each of :data:`SPEED_FACTORS` (not for the sine, whose turns
    tighten as it slows). ``"both"``: the widest turns with each slower speed. Each change is
    ``(kind, settings)``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    """
    ref = cfg.reference.kwargs()
    kind = cfg.reference.kind
    turns: list[tuple[Setting, ...]] = []
    for f in TURN_FACTORS:
        if kind == "lawnmower":
            turns.append(
                (
                    Setting("reference", "turn_radius", ref["turn_radius"] * f),
                    Setting("reference", "spacing", ref["spacing"] * f),
                )
            )
        elif kind == "circle":
            turns.append((Setting("reference", "radius", ref["radius"] * f),))
        elif kind == "sine":
            # rounded down (a lower frequency turns gentler) to the digits a user writes: each change is
            # certified as written
            omega = significant(ref["omega"] / math.sqrt(f), ADVISED_DIGITS, up=False)
            turns.append((Setting("reference", "omega", omega),))
    speeds = [] if kind == "sine" else [(Setting("reference", "speed", ref["speed"] * f),) for f in SPEED_FACTORS]
    out = [("turns", t) for t in turns] + [("speed", v) for v in speeds]
    if turns:
        out += [("both", turns[-1] + v) for v in speeds]
    return out


def _candidates(cfg: FormationConfig) -> list[tuple[str, tuple[Setting, ...]]]:
    """The changes to try, in order (see the module docstring)."""
    design: tuple[Setting, ...] = ()
    out: list[tuple[str, tuple[Setting, ...]]] = []
    if cfg.synthesis != "deployed" or not cfg.robust:
        design = (Setting("design", "robust", True), Setting("design", "synthesis", "deployed"))
        out.append(("design", design))
    return out + [(what, design + settings) for what, settings in mission_changes(cfg)]


#: How a change of each kind that certifies is named in an answer.
CHANGE_WORDS = {
    "design": "gains designed for the deployed loop",
    "turns": "wider turns",
    "speed": "a slower mission",
    "both": "wider turns at a slower speed",
}
#: How each kind of change is named in a refusal that lists what was tried.
TRIED = {
    "design": CHANGE_WORDS["design"],
    "turns": f"turns up to {TURN_FACTORS[-1]:g} times wider",
    "speed": "half and a quarter of the mission speed",
    "both": "the widest turns at the slower speeds",
}


def tried(cfg: FormationConfig) -> str:
    """The kinds of change :func:`mission_advice` tries on ``cfg``, in words (for a refusal when none covers).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    """
    kinds = list(dict.fromkeys(what for what, _ in _candidates(cfg)))
    return ", ".join(TRIED[k] for k in kinds)


def mission_advice(
    point: DesignPoint, bound: Callable[[FormationConfig, tuple[Setting, ...]], float | None]
) -> tuple[MissionAdvice, ...]:
    """The first covering change of each kind (design, turns, speed), in that order.

    Stops at the first kind that covers: a design change is proposed alone when it certifies,
    and the turns before the speed.

    Parameters
    ----------
    point : DesignPoint
        The design point whose composed certificate does not cover, with no declared setting.
    bound : callable
        The covered position bound (m) of the configuration rewritten with some settings, or
        ``None`` when it does not cover (the composed part designs it and computes its composed
        certificate, as a re-run does).
    """
    cfg = point.config
    candidates = _candidates(cfg)
    with tqdm(total=len(candidates), unit="design", desc="mission advice", leave=False) as bar:
        for what, settings in candidates:
            b = bound(cfg, settings)
            bar.update(1)
            if b is not None:
                return (MissionAdvice(what, settings, b),)
    return ()


__all__ = [
    "CHANGE_WORDS",
    "SPEED_FACTORS",
    "TRIED",
    "TURN_FACTORS",
    "MissionAdvice",
    "mission_advice",
    "mission_changes",
    "tried",
]
