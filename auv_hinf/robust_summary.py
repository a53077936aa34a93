"""The robust part of a certificate and of a run: from a configuration to the ``robust`` object.

:func:`robust_gains` gives the gains every command uses (the robust design when
``[design] robust = true``, else the Theorem 1 gains); :func:`robust_summary` certifies them
for the declared ``[uncertainty]`` box and ``[disturbance]`` current along the mission, with
margins and the weakest corner; :func:`check_robust_run` says whether one simulated run
(plant, current, start) is covered and gives its certified bounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from ._typing import FloatArray
from .closed_loop import ClosedLoopCertificate
from .config import FormationConfig
from .coverage import initial_errors
from .envelope import Envelope
from .exceptions import AuvHinfError
from .margins import ErrorBounds
from .reference import FleetReference, ReferenceTube, reference_from_dict
from .robust import RobustCertificate, RobustGains, robust_certificate
from .robust_design import RobustDesign, design_robust
from .robust_margin import RobustMargin, Witness, robust_margin, weakest_corner
from .settings import ReferenceConfig
from .tubes import fleet_tube, mission_tube
from .uncertainty import PARAMETERS, ParameterBox, TubeSummary, current_offset
from .vehicle import VehicleParams

#: Largest fleet whose own shaped tube is built to check a run (the tube costs ~0.1-1 s a vehicle).
RUN_TUBE_MAX_N = 16
#: Relative tolerance of the plant-in-box and current-in-disc tests (round-off of TOML decimals).
BOX_RTOL = 1e-12


def declared_box(cfg: FormationConfig) -> ParameterBox:
    """The ``[uncertainty]`` box around the configured vehicle."""
    return ParameterBox.from_ranges(cfg.vehicle, cfg.uncertainty.box)


def declared_current(cfg: FormationConfig) -> float:
    """The ``[disturbance]`` current bound (m/s, 0 when absent)."""
    return float(cfg.disturbance.current_speed or 0.0)


@lru_cache(maxsize=32)
def _design(
    vehicle: VehicleParams,
    box: tuple[tuple[str, tuple[float, float]], ...],
    current: float,
    envelope: Envelope,
    reference: ReferenceConfig,
    thrust_limit: tuple[float, float, float] | None,
) -> RobustDesign:
    return design_robust(
        ParameterBox.from_ranges(vehicle, box),
        envelope,
        mission_tube(reference_from_dict(reference.kind, **reference.kwargs())),
        current,
        thrust_limit,
        progress=True,
    )


def robust_design_for(cfg: FormationConfig) -> RobustDesign:
    """The robust design of ``cfg``, cached on what it depends on (vehicle, box, current, envelope,
    mission and thrust limit), so runs that differ only in their start or plant share it."""
    return _design(
        cfg.vehicle,
        cfg.uncertainty.box,
        declared_current(cfg),
        cfg.envelope,
        cfg.reference,
        cfg.simulation.thrust_limit,
    )


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
    reasons : tuple of str
    """

    declared: bool
    certificate: RobustCertificate | None
    margin: RobustMargin | None
    worst: Witness | None
    design: RobustDesign | None
    nominal_rate: float | None
    reasons: tuple[str, ...]
    gains: RobustGains | None = None

    @property
    def covers(self) -> bool:
        """The robust certificate covers the declared box and current (the nominal loop when none)."""
        if not self.declared:
            return self.nominal_rate is not None and not self.reasons
        return self.certificate is not None and self.certificate.covers and not self.reasons

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
            "reasons": list(self.reasons) + ([] if c is None else list(c.reasons)),
        }


def robust_gains(cfg: FormationConfig) -> RobustGains:
    """The gains of ``cfg``: the robust design's when ``cfg.robust``, else Theorem 1's."""
    if cfg.robust:
        return robust_design_for(cfg).gains
    from .plan import design_gains

    g = design_gains(cfg)
    return RobustGains(g.alpha, g.k1, g.k_psi)


def _tube_and_speed(cfg: FormationConfig) -> tuple[ReferenceTube, float]:
    from .plan import mission_reference

    tube = mission_tube(mission_reference(cfg))
    return tube, TubeSummary.of(tube).speed[1]


def robust_summary(
    cfg: FormationConfig, *, margins: bool = True, nominal: ClosedLoopCertificate | None = None
) -> RobustSummary:
    """Certify ``cfg``'s gains for its declared box and current (see the module docstring).

    ``nominal`` is the nominal closed-loop certificate of ``cfg``'s gains along the mission
    (``closed_loop_for(cfg, design_gains(cfg))``) when the caller has it already; otherwise it
    is computed here. It supplies the envelope and heading-range checks and, with nothing
    declared, the whole summary: its decay rate, errors converging to zero, no margins.
    """
    from .plan import closed_loop_for, design_gains

    box, current = declared_box(cfg), declared_current(cfg)
    declared = box.declared or current > 0.0
    design = robust_design_for(cfg) if cfg.robust else None
    try:
        gains = robust_gains(cfg)
        tube, speed = _tube_and_speed(cfg)
        if nominal is None:
            nominal = closed_loop_for(cfg, design_gains(cfg))
    except AuvHinfError as exc:
        return RobustSummary(declared, None, None, None, design, None, (f"not certified: {exc}",))
    if not declared:
        return RobustSummary(False, None, None, None, design, nominal.rate, (), gains)
    reasons: list[str] = []
    if cfg.disturbance.current_rate:
        reasons.append(
            "a time-varying current (current_rate > 0) is not certified: the certificate assumes it constant"
        )
    cert = robust_certificate(box, cfg.envelope, tube, gains, current, cfg.simulation.thrust_limit)
    margin = None
    if margins and cert.stable:

        def covers(s: float) -> bool:
            return robust_certificate(
                box.scaled(s), cfg.envelope, tube, gains, current * s, cfg.simulation.thrust_limit
            ).covers

        margin = robust_margin(box, gains, speed, current, covers)
    worst = weakest_corner(box, gains, speed, current)
    return RobustSummary(True, cert, margin, worst, design, None, tuple(reasons), gains)


@dataclass(frozen=True)
class RobustRunCheck:
    """The robust certificate's verdict on one run.

    Attributes
    ----------
    covered : bool
    bounds : dict or None
        Certified per-vehicle error bounds for this run (m, m/s, rad, rad/s).
    reason : str
    """

    covered: bool
    bounds: dict[str, float] | None
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {"covered": self.covered, "bounds": self.bounds, "reason": self.reason}


def _in_box(cfg: FormationConfig, box: ParameterBox) -> str | None:
    mult = dict(cfg.simulation.plant)
    for k, name in enumerate(PARAMETERS):
        m = float(mult.get(name, 1.0))
        if not (box.lo[k] * (1 - BOX_RTOL) <= m <= box.hi[k] * (1 + BOX_RTOL)):
            return f"plant multiplier {name} = {m:g} is outside the declared box [{box.lo[k]:g}, {box.hi[k]:g}]"
    return None


def check_robust_run(cfg: FormationConfig, fleet: FleetReference, initial: FloatArray) -> RobustRunCheck:
    """Is the run of ``cfg`` tracking ``fleet`` from ``initial`` covered by the robust certificate?

    Covered when the plant is in the declared box, the current within the declared bound, the
    certificate (on the mission tube and, for a shaped start, the run's own tube) covers, and
    every vehicle starts inside both certified ellipsoids.
    """
    box, bound = declared_box(cfg), declared_current(cfg)
    cur = np.asarray(cfg.simulation.current, dtype=float)
    why = _in_box(cfg, box)
    if why is None and float(np.hypot(*cur)) > bound * (1 + BOX_RTOL):
        why = f"current {float(np.hypot(*cur)):.4g} m/s exceeds the declared bound {bound:g} m/s"
    if why is None and cfg.disturbance.current_rate:
        why = "a time-varying current is not certified"
    if why is not None:
        return RobustRunCheck(False, None, why)
    try:
        tube, _ = _tube_and_speed(cfg)
        if fleet.shaping is not None:
            if cfg.n > RUN_TUBE_MAX_N:
                return RobustRunCheck(
                    False, None, f"not evaluated: shaped start of more than {RUN_TUBE_MAX_N} vehicles"
                )
            tube = ReferenceTube.concatenate([tube, fleet_tube(fleet)])
        cert = robust_certificate(box, cfg.envelope, tube, robust_gains(cfg), bound, cfg.simulation.thrust_limit)
    except AuvHinfError as exc:
        return RobustRunCheck(False, None, f"not certified: {exc}")
    if not cert.covers or cert.bounds is None:
        return RobustRunCheck(False, None, "; ".join(cert.reasons) or "the robust certificate does not cover")
    b = cert.bounds
    bounds = {"position": b.position, "velocity": b.velocity, "heading": b.heading, "yaw_rate": b.yaw_rate}
    e, de, epsi, depsi = initial_errors(fleet, initial, (float(cur[0]), float(cur[1])))
    if not cert.start_inside(e, de, epsi, depsi, cur):
        return RobustRunCheck(False, bounds, "the start is outside the certified invariant set")
    return RobustRunCheck(True, bounds, "covered: plant and current declared, start inside the certified set")


__all__ = [
    "RobustRunCheck",
    "RobustSummary",
    "check_robust_run",
    "current_offset",
    "declared_box",
    "declared_current",
    "robust_design_for",
    "robust_gains",
    "robust_summary",
]
