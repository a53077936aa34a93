"""The certificate-part protocol: what every part of a certificate gives, as data.

A certificate is a sequence of parts (the paper's Theorem 1, the closed loop along the
mission, the robust certificate of a declared box and current, the actuators, the
implementation, and any part registered later). Each part takes the design point and the
verdicts of the parts before it, and returns a :class:`Verdict`:

* whether it holds, and whether it applies to what was declared;
* its :class:`Reason`\\ s, as data: the part, a kind from :data:`REASON_KINDS`, the channel,
  the vehicle, the value and the limit, and the :class:`Setting`\\ s of the configuration
  that would change the verdict (a TOML table, a key and a value), next to the sentence a
  person reads;
* its figures: the JSON object ``certify --json`` prints under the part's key (or at the top
  level for a part whose ``key`` is ``None``);
* the commanded-force bounds it proves (N, N, N m), which the actuator part holds against the
  limits, and what binds it, if it is the design's limit.

Its text section is written from its figures alone, so a certificate read back from its file
prints the same text as the one just computed. No code decides anything from the words of a
reason: verdicts route on ``ok``, ``applies``, ``kind`` and the other fields.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol

from auv_hinf.certificate.reason import Reason

if TYPE_CHECKING:
    from auv_hinf.certificate.design_point import DesignPoint


# A commanded-force bound (|tau_x|, |tau_y|, |tau_psi|) (N, N, N m): a plain alias, left out of the API pages.
Peak = tuple[float, float, float]

#: Relative tolerance of a run's plant-in-box and current-in-disc tests: the round-off of decimals
#: written to a TOML file. A current at the bound in a diagonal direction written with 12 digits,
#: ``0.1 (cos 45 deg, sin 45 deg)``, has a norm 5e-12 above 0.1 (a review's sweep found every such run
#: called "outside the bound" at 1e-12); 1e-9 holds ten significant digits, and is below what any
#: certificate resolves (their fixed points are inflated by at least 1e-9).
RUN_RTOL = 1e-9


def figures_in(entry: Mapping[str, Any], record: Mapping[str, Any]) -> Any:
    """The figures, in a certificate ``record``, of the part whose ``parts`` entry is ``entry``.

    Parameters
    ----------
    entry : mapping
        The part's entry of the record's ``parts`` object (its ``key``, or its ``keys``).
    record : mapping
        The whole certificate record.
    """
    key = entry.get("key")
    if key is not None:
        return record.get(key)
    return {k: record[k] for k in entry.get("keys", ()) if k in record}


@dataclass(frozen=True)
class Verdict:
    """What one part says about a design.

    Attributes
    ----------
    part : str
        The part's registry name.
    ok : bool
        The part holds (a part that does not apply holds).
    applies : bool
        The part is about something the configuration declares or the design needs.
    reasons : tuple of Reason
        Why it does not hold (empty when it does).
    figures : Mapping
        The part's JSON object (``None`` when it has none to report).
    peaks : tuple of Peak
        Commanded-force bounds the part proves (N, N, N m).
    binding : str, optional
        What limits the design, when this part is what binds it (one line).
    detail : Any
        The part's typed result (certificates, matrices); ``None`` for a certificate read back
        from its file, which keeps the figures only.
    key : str or None
        The JSON key of the figures (set by the assembly from the part; ``None``: top-level keys).
    note : str or None
        Where the verdict comes from, when it is not a part of this session (a stored record).
    position_bound : float or None
        The sup over all ``t >= 0`` of every vehicle's position error ``||p_i - p_d,i||`` (m) that
        this part proves for the configured start, on the system it models (``None``: it proves
        none; a bound that holds only as ``t -> inf`` is not one). The separation part reads it.
    bound_reference : Any
        The :class:`~auv_hinf.mission.fleet.FleetReference` ``p_d`` that ``position_bound`` is
        measured against (``None``: the raw mission, no shaped start).
    """

    part: str
    ok: bool
    applies: bool = True
    reasons: tuple[Reason, ...] = ()
    figures: Any = None
    peaks: tuple[Peak, ...] = ()
    binding: str | None = None
    detail: Any = field(default=None, compare=False)
    key: str | None = None
    note: str | None = None
    position_bound: float | None = None
    bound_reference: Any = field(default=None, compare=False)

    def record(self) -> dict[str, Any]:
        """The verdict's entry in ``certify --json``'s ``parts`` object.

        ``key`` is where its figures are; a part whose figures are top-level keys lists them
        under ``keys`` instead.
        """
        out: dict[str, Any] = {
            "ok": self.ok,
            "applies": self.applies,
            "reasons": [r.to_dict() for r in self.reasons],
            "key": self.key,
        }
        if self.key is None:
            out["keys"] = list(self.figures or {})
        if self.note is not None:
            out["note"] = self.note
        return out

    @classmethod
    def restored(cls, part: str, entry: Mapping[str, Any], record: Mapping[str, Any]) -> Verdict:
        """The verdict of a stored certificate: its ``parts`` entry and its figures in ``record``, no detail.

        Parameters
        ----------
        part : str
            The part's registry name.
        entry : mapping
            Its entry of the record's ``parts`` object.
        record : mapping
            The whole certificate record.
        """
        key = entry.get("key")
        figures = figures_in(entry, record)
        return cls(
            part=part,
            ok=bool(entry["ok"]),
            applies=bool(entry["applies"]),
            reasons=tuple(Reason.from_dict(r) for r in entry["reasons"]),
            figures=figures,
            key=key,
            note=entry.get("note"),
        )


@dataclass(frozen=True)
class PartContext:
    """What a part sees: the design point and the verdicts of the parts before it.

    Attributes
    ----------
    point : DesignPoint
        The design of the configuration (gains, mission, tube, box, current, ...).
    verdicts : Mapping of str to Verdict
        The verdicts so far, by part name, in registry order.
    options : Mapping
        Options of the ``certify`` call (e.g. ``jacobi_samples``), read by the parts they concern.
    """

    point: DesignPoint
    verdicts: Mapping[str, Verdict]
    options: Mapping[str, Any] = field(default_factory=dict)

    def detail(self, name: str) -> Any:
        """The typed result of an earlier part (``None`` when it did not run or gave none).

        Parameters
        ----------
        name : str
            The earlier part's registry name.
        """
        v = self.verdicts.get(name)
        return None if v is None else v.detail

    def holds_so_far(self) -> bool:
        """Every earlier part holds."""
        return all(v.ok for v in self.verdicts.values())

    def peaks(self) -> list[Peak]:
        """Every force bound the earlier parts prove (N, N, N m)."""
        return [p for v in self.verdicts.values() for p in v.peaks]


#: How a part's verdict on one run combines with the others': a run is covered when some
#: applicable ``certificate`` covers it and every applicable ``condition`` holds.
RunRole = Literal["certificate", "condition"]

#: The control laws a fleet can run: the paper's fully actuated formation law, or the
#: line-of-sight guidance cascade of a ``[guidance]`` table (:mod:`auv_hinf.guidance`).
ControlLaw = Literal["formation", "guidance"]
#: The laws of a part that judges whatever the fleet runs (the default of a part that does not say).
ALL_LAWS: tuple[ControlLaw, ...] = ("formation", "guidance")
#: The laws of a part about the fully actuated formation law only.
FORMATION_LAW: tuple[ControlLaw, ...] = ("formation",)
#: The note of a part whose law does not run, by the law that runs instead.
LAW_IDLE: dict[ControlLaw, str] = {
    "guidance": "the fully actuated formation law does not run: [guidance] steers the fleet",
    "formation": "the guidance cascade does not run: the fully actuated formation law steers the fleet",
}


def control_law(guided: bool) -> ControlLaw:
    """The law a fleet runs: ``"guidance"`` with a ``[guidance]`` table, else ``"formation"``.

    Parameters
    ----------
    guided : bool
        The configuration has a ``[guidance]`` table.
    """
    return "guidance" if guided else "formation"


def part_laws(part: object) -> tuple[ControlLaw, ...]:
    """The laws ``part`` judges: its ``laws``, or :data:`ALL_LAWS` for a part that does not declare them.

    Parameters
    ----------
    part : CertificatePart
        A registered part (a plug-in written before ``laws`` existed judges every law).
    """
    laws: tuple[ControlLaw, ...] = getattr(part, "laws", ALL_LAWS)
    return laws


@dataclass(frozen=True)
class RunContext:
    """What a part sees when it judges one run: the design, the start, the horizon, earlier checks.

    Attributes
    ----------
    point : DesignPoint
    initial : ndarray, shape (N, 6)
        The run's initial states ``[x, y, psi, u, v, r]`` (m, rad, m/s, rad/s).
    start : {"shaped", "paper"}
        The start mode.
    horizon : float
        The run's horizon (s).
    checks : Mapping of str to RunCheck
        The checks of the parts before it.
    """

    point: DesignPoint
    initial: Any
    start: str
    horizon: float
    checks: Mapping[str, RunCheck] = field(default_factory=dict)

    @property
    def reference(self) -> Any:
        """The fleet reference the run tracks: the first one an earlier check chose, else the raw mission."""
        chosen = next((c.reference for c in self.checks.values() if c.reference is not None), None)
        return self.point.fleet() if chosen is None else chosen


@dataclass(frozen=True)
class RunCheck:
    """One part's verdict on one run.

    Attributes
    ----------
    part : str
    role : {"certificate", "condition"}
        See :data:`RunRole`.
    applies : bool
        The part has something to say about this run.
    covers : bool
        It covers the run (a certificate) or the run meets it (a condition).
    reason : str
        One line on the verdict.
    notes : tuple of str
        Lines for the run's ``coverage_reason``.
    bounds : dict or None
        Certified per-vehicle error bounds of the run (m, m/s, rad, rad/s), when it covers.
    thrust : Any
        The certified commanded-force bound of the run (:class:`~auv_hinf.actuation.thrust.ThrustBounds`).
    reference : Any
        The fleet reference this part chose for the run (a shaped start), if any.
    refuses_gains : str or None
        Why no certificate covers the gains themselves (``simulate`` refuses them without
        ``--uncertified``), whatever this run's start.
    certifies_gains : bool
        The part's certificate covers the gains themselves, whatever this run (its plant, current
        or start): the parts it supersedes then cannot refuse them.
    detail : Any
        The part's typed result on the run.
    """

    part: str
    role: RunRole
    applies: bool
    covers: bool
    reason: str = ""
    notes: tuple[str, ...] = ()
    bounds: dict[str, float] | None = None
    thrust: Any = None
    reference: Any = None
    refuses_gains: str | None = None
    certifies_gains: bool = False
    detail: Any = field(default=None, compare=False)


def run_covered(checks: Sequence[RunCheck]) -> bool:
    """Some applicable certificate covers the run and every applicable condition holds.

    Parameters
    ----------
    checks : sequence of RunCheck
        The parts' verdicts on the run.
    """
    certificates = [c for c in checks if c.applies and c.role == "certificate"]
    conditions = [c for c in checks if c.applies and c.role == "condition"]
    return any(c.covers for c in certificates) and all(c.covers for c in conditions)


class CertificatePart(Protocol):
    """One part of a certificate (see the module docstring).

    Attributes
    ----------
    name : str
        The registry name (the key of the ``parts`` object of ``certify --json``).
    key : str or None
        The JSON key of the part's figures (``None``: the figures are top-level keys).
    laws : tuple of {"formation", "guidance"}
        The control laws the part judges (:data:`ALL_LAWS` or :data:`FORMATION_LAW`); the assembly
        does not evaluate a part whose law the fleet does not run, and marks it with
        :data:`LAW_IDLE`. Optional: a part without it judges every law (:func:`part_laws`).
    idle_notes : dict
        Optional: the part's own note when its law does not run, by the law that runs instead (what
        covers its concern then), in place of :data:`LAW_IDLE`.
    """

    @property
    def name(self) -> str:
        """The registry name."""
        ...

    @property
    def key(self) -> str | None:
        """The JSON key of the figures (``None``: at the top level)."""
        ...

    def evaluate(self, ctx: PartContext) -> Verdict:
        """The part's verdict on ``ctx.point`` given the earlier verdicts.

        Parameters
        ----------
        ctx : PartContext
            The design point and the earlier verdicts.
        """
        ...

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The part's section of the readable table, from its figures (and the whole record).

        Parameters
        ----------
        figures : Any
            The part's figures in the record.
        record : mapping
            The whole certificate record.
        """
        ...

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """The part's verdict on one run (``None``: the part says nothing about runs).

        Parameters
        ----------
        ctx : RunContext
            The run and the checks of the parts before.
        """
        ...


def reasons_of(verdicts: Sequence[Verdict]) -> tuple[Reason, ...]:
    """Every reason of the verdicts that do not hold, in order.

    Parameters
    ----------
    verdicts : sequence of Verdict
        The verdicts.
    """
    return tuple(r for v in verdicts if not v.ok for r in v.reasons)


__all__ = [
    "ALL_LAWS",
    "FORMATION_LAW",
    "LAW_IDLE",
    "CertificatePart",
    "ControlLaw",
    "PartContext",
    "Peak",
    "RunCheck",
    "RunContext",
    "RunRole",
    "Verdict",
    "control_law",
    "figures_in",
    "part_laws",
    "reasons_of",
    "run_covered",
]
