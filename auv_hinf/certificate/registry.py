"""The registry of certificate parts: which parts every certificate has, in the order they run.

:data:`PARTS` lists the toolbox's parts; a part may read the verdicts of the parts before it
(the robust part reuses the closed-loop certificate, the actuator part holds every earlier
part's force bounds against the limits). Adding a part to the toolbox is one new module and
one line here. A part may *supersede* others (``supersedes``: the parts that certify idealisations
of the loop it certifies as it runs): when it covers, they are not evaluated
(:func:`superseded_by`). :func:`register_part` adds a part at run time (a plug-in, or a test), and
:func:`unregister_part` removes it again.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from auv_hinf.certificate.part import CertificatePart, Verdict
from auv_hinf.certificate.parts.actuators import ActuatorPart
from auv_hinf.certificate.parts.closed_loop import ClosedLoopPart
from auv_hinf.certificate.parts.composed import ComposedPart
from auv_hinf.certificate.parts.guidance import GuidancePart
from auv_hinf.certificate.parts.implementation import ImplementationPart
from auv_hinf.certificate.parts.robust import RobustPart
from auv_hinf.certificate.parts.separation import SeparationPart
from auv_hinf.certificate.parts.theorem1 import Theorem1Part
from auv_hinf.exceptions import ParameterError

#: The toolbox's parts, in evaluation order.
PARTS: tuple[CertificatePart, ...] = (
    Theorem1Part(),
    ComposedPart(),
    ClosedLoopPart(),
    RobustPart(),
    GuidancePart(),
    ActuatorPart(),
    ImplementationPart(),
    SeparationPart(),
)

_registered: list[CertificatePart] = list(PARTS)


def parts() -> tuple[CertificatePart, ...]:
    """The parts every certificate is assembled from now, in evaluation order."""
    return tuple(_registered)


def part_named(name: str) -> CertificatePart | None:
    """The registered part called ``name`` (``None``: not registered).

    Parameters
    ----------
    name : str
        The part's registry name.
    """
    return next((p for p in _registered if p.name == name), None)


def register_part(part: CertificatePart, *, after: str | None = None) -> None:
    """Add ``part`` to every certificate from now on: last, or right after the part named ``after``.

    Parameters
    ----------
    part : CertificatePart
        The part; its name and (non-None) key must be new.
    after : str, optional
        Name of the registered part it follows; default last.

    Raises
    ------
    ParameterError
        If a part of that name is registered already, its key is taken, or ``after`` is unknown.
    """
    if part_named(part.name) is not None:
        raise ParameterError(f"a certificate part called {part.name!r} is registered already")
    if part.key is not None and any(p.key == part.key for p in _registered):
        raise ParameterError(f"the JSON key {part.key!r} belongs to another certificate part")
    if after is None:
        _registered.append(part)
        return
    names = [p.name for p in _registered]
    if after not in names:
        raise ParameterError(f"no certificate part called {after!r} (parts: {names})")
    _registered.insert(names.index(after) + 1, part)


def unregister_part(name: str) -> None:
    """Remove the part called ``name`` (one of the toolbox's own parts cannot be removed).

    Parameters
    ----------
    name : str
        The part's registry name.

    Raises
    ------
    ParameterError
        If no such part is registered, or it is one of :data:`PARTS`.
    """
    part = part_named(name)
    if part is None:
        raise ParameterError(f"no certificate part called {name!r}")
    if any(p.name == name for p in PARTS):
        raise ParameterError(f"{name!r} is one of the toolbox's own certificate parts")
    _registered.remove(part)


def part_supersedes(name: str) -> tuple[str, ...]:
    """The parts that the part called ``name`` supersedes when it covers (its ``supersedes``; none by default).

    Parameters
    ----------
    name : str
        A registered part's name.
    """
    part = part_named(name)
    return tuple(getattr(part, "supersedes", ())) if part is not None else ()


def superseded_by(name: str, earlier: Mapping[str, Any]) -> str | None:
    """The earlier part whose covering verdict (or run check) supersedes the part called ``name``, if any.

    A part that certifies a loop *as it runs* (the composed certificate) makes the parts that
    certify idealisations of it redundant when it covers: they are then not evaluated.

    Parameters
    ----------
    name : str
        The part about to be evaluated.
    earlier : mapping of str to Verdict or RunCheck
        The verdicts (or run checks) so far, by part name.
    """
    for other, v in earlier.items():
        holds = v.ok if isinstance(v, Verdict) else v.covers
        if v.applies and holds and name in part_supersedes(other):
            return other
    return None


def superseded_figures(by: str, name: str, figures: Any) -> Any:
    """The figures the superseding part ``by`` reports for the part ``name`` it supersedes (``None``: none).

    A superseding part may keep a superseded part's JSON object alive with what it proves in that
    part's terms (its ``superseded_figures(name, figures)``), so readers of that object find the
    verdict there too.

    Parameters
    ----------
    by : str
        The superseding part's name.
    name : str
        The superseded part's name.
    figures : Any
        The superseding part's own figures.
    """
    part = part_named(by)
    make = getattr(part, "superseded_figures", None)
    return None if make is None else make(name, figures)


__all__ = [
    "PARTS",
    "part_named",
    "part_supersedes",
    "parts",
    "register_part",
    "superseded_by",
    "superseded_figures",
    "unregister_part",
]
