"""Which constraint binds a certificate, and the force bounds it proves.

:func:`binding_constraint` names what limits the certified design (the implementation, the
actuators or the envelope); :func:`certified_peaks` lists the thrust bounds the certificate
proves (nominal region, the checked shaped start, the robust set).
"""

from __future__ import annotations

from auv_hinf.workflow.actuator_check import ActuatorCheck
from auv_hinf.workflow.implementation_part import ImplementationSummary
from auv_hinf.workflow.nominal import ClosedLoopSummary
from auv_hinf.workflow.robust_part import RobustSummary

#: An actuator channel counts as the binding constraint when the certified peak reaches this
#: share of its limit (the region is shrunk to fit the limits, so a binding channel sits at 1).
ACTUATOR_BINDING_RATIO = 0.99


def binding_constraint(
    act: ActuatorCheck, rob: RobustSummary, loop: ClosedLoopSummary | None, impl: ImplementationSummary
) -> str | None:
    """The constraint that limits the certified design: the implementation, actuators, the envelope, or none found."""
    c, run = impl.certificate, impl.implementation
    if not run.continuous and not impl.covers and c is not None:
        return (
            f"implementation (sample time {run.sample_time:.3g} s, delay {run.delay:.3g} s; "
            f"certified sample time up to {c.max_sample_time:.3g} s)"
        )
    if act.limits is not None and act.binding is not None and act.binding_ratio is not None:
        if act.binding_ratio >= ACTUATOR_BINDING_RATIO:
            return f"actuators ({act.binding}, {act.binding_ratio:.3g} of its limit)"
    margins = rob.certificate.margins if rob.declared and rob.certificate is not None else None
    if margins is None and loop is not None and loop.certificate is not None:
        margins = loop.certificate.region.margins
    if margins is not None:
        return f"operating envelope (smallest margin {margins.min:.3g})"
    return None


def certified_peaks(loop: ClosedLoopSummary | None, rob: RobustSummary) -> list[tuple[float, float, float]]:
    """The thrust bounds the certificate proves: nominal region, checked shaped start, robust set."""
    out = []
    if loop is not None and loop.certificate is not None:
        out.append(loop.certificate.thrust.as_tuple())
        if loop.shaped is not None and loop.shaped.covered and loop.shaped.thrust is not None:
            out.append(loop.shaped.thrust.as_tuple())
    c = rob.certificate
    if rob.declared and c is not None and c.thrust is not None:
        out.append(c.thrust.as_tuple())
    return out


__all__ = ["ACTUATOR_BINDING_RATIO", "binding_constraint", "certified_peaks"]
