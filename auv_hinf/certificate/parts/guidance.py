"""The guidance part: the line-of-sight cascade of a propeller-and-rudder fleet, and what is proved of it.

A configuration with a ``[guidance]`` table steers every vehicle with the cascade of
:mod:`auv_hinf.guidance.law` (ILOS or LOS on its slot path, along-track speed coordination,
surge and heading autopilots on the propeller and the rudder), not with the fully actuated
formation law. This version proves no bound for that cascade: the part applies, does not hold,
and says so, so that a fleet that runs it is never called certified. Its figures are the
``guidance`` object of ``certify --json``: the kind, the lookahead, the gains, ``certified``
(false) and ``error_bounds`` (``null``: none is claimed). ``auv-hinf simulate`` runs the cascade
and reports the measured along-track, cross-track and heading errors, the rudder and the thrust.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from auv_hinf.certificate.part import PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.reason import Reason

#: The part's registry name.
PART = "guidance"
#: The JSON key of its figures.
KEY = "guidance"


def guidance_figures(ctx: PartContext) -> dict[str, Any] | None:
    """The ``guidance`` object of ``certify --json`` (``None`` without ``[guidance]``).

    Parameters
    ----------
    ctx : PartContext
        The design point (its configuration's ``[guidance]`` table).
    """
    g = ctx.point.config.guidance
    if g is None:
        return None
    return {
        **g.to_dict(),
        "certified": False,
        "error_bounds": None,
        "certified_peak": None,
        "reason": (
            f"no certificate of the {g.kind.upper()} guidance cascade in this version: no bound of its "
            "along-track, cross-track or heading errors, rudder or thrust is claimed; `auv-hinf simulate` "
            "runs it on the 3-DOF model and reports what it measures"
        ),
    }


@dataclass(frozen=True)
class GuidancePart:
    """The guidance cascade's verdict: it applies with ``[guidance]`` and, in this version, never holds.

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
        """Not certified with ``[guidance]`` (see the module docstring); does not apply without it.

        Parameters
        ----------
        ctx : PartContext
            The design point and the earlier verdicts.
        """
        figures = guidance_figures(ctx)
        if figures is None:
            return Verdict(self.name, True, False)
        why = Reason(self.name, "unsupported", f"guidance: {figures['reason']}", channel="guidance")
        return Verdict(self.name, False, True, (why,), figures)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """The guidance kind, its lookahead and gain, and that no bound is certified.

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
        return [f"  guidance ({f['kind']})           lookahead {f['lookahead']:.4g} m,{gain} not certified: no bound"]

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """Nothing to say about a run of the fully actuated law (a guidance run is simulated on its own).

        Parameters
        ----------
        ctx : RunContext
            The run.
        """
        return None


__all__ = ["KEY", "PART", "GuidancePart", "guidance_figures"]
