"""The one home of a configuration's design: everything a command derives before it certifies or simulates.

:func:`design_point` computes, once per command, the envelope ``lam``, the certified
``sigma``, ``gamma``, the Theorem 1 gain of every method, the :class:`~auv_hinf.law.gains.Gains`
that run (Theorem 1's, or the robust design's when ``[design] robust = true``), the mission
reference, its tube and the formation offsets. :func:`~auv_hinf.certificate.assembly.certify`,
:func:`~auv_hinf.certificate.run_plan.plan_run`, campaigns and the python-control export all
take this object, so no command derives the gains twice and every report shows the gains
that run.

The result is cached on what the design depends on (vehicle, envelope, formation, design
table, mission, declared box and current, actuator limits), so runs that differ only in their
start, plant or horizon share one design.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

import numpy as np

from auv_hinf._typing import GAIN_METHODS, FloatArray
from auv_hinf.certificate.deployed import deployed_problem
from auv_hinf.certificate.reason import Reason
from auv_hinf.composed.synthesis import OBJECTIVE as DEPLOYED_OBJECTIVE
from auv_hinf.composed.synthesis import DeployedDesign, synthesise_deployed
from auv_hinf.config.schema import DEFAULT_MIN_SEPARATION, DEFAULT_SYNTHESIS
from auv_hinf.config.settings import FormationConfig, SimulationConfig
from auv_hinf.design.sigma import SigmaBounds, vehicle_sigma
from auv_hinf.design.theorem1 import GainDesign, design_alpha
from auv_hinf.exceptions import AuvHinfError, ConfigError, DesignError
from auv_hinf.implementation.model import Implementation
from auv_hinf.law.gains import Gains, GainSource, heading_gains
from auv_hinf.mission.fit import ReferenceFit, reference_fit
from auv_hinf.mission.fleet import FleetReference, ReferenceTube, reference_from_dict
from auv_hinf.mission.paths import MissionReference
from auv_hinf.mission.tubes import mission_tube, path_frame_tube
from auv_hinf.models.envelope import envelope_lambda
from auv_hinf.models.jacobi import positions_from_jacobi
from auv_hinf.robust.bandwidth import RobustDesign, design_robust
from auv_hinf.robust.box import ParameterBox
from auv_hinf.robust.synthesis import OBJECTIVE as SYNTHESIS_OBJECTIVE
from auv_hinf.robust.synthesis import synthesise_robust

#: The gains a deployed problem is built with before the search replaces them (any valid gains).
PLACEHOLDER_GAINS = Gains(1.0, 1.0, (1.0, 1.0))

#: Where the gains that run come from.


@dataclass(frozen=True, eq=False)
class DesignPoint:
    """The design of one configuration, computed once (see the module docstring).

    Attributes
    ----------
    config : FormationConfig
        The configuration it was computed for.
    lam : float
        Envelope lambda (1/s): ``cfg.lam`` or :func:`~auv_hinf.models.envelope.envelope_lambda`.
    sigma : SigmaBounds
        Certified vehicle-coordinate bound of ``||G_i - lam I||`` (1/s).
    gamma : float
        H-infinity bound (s): ``cfg.gamma`` or ``1/sigma.upper``.
    designs : dict
        Theorem 1 :class:`~auv_hinf.design.theorem1.GainDesign` of every method, ``None`` where
        the method is infeasible.
    gains : Gains or None
        The gains that run; ``None`` when the design gives none (see ``reasons``).
    source : {"theorem1", "robust"}
        Where ``gains`` come from.
    robust_design : RobustDesign or None
        The robust design, when ``[design] robust = true`` with the bandwidth or LMI synthesis.
    deployed_design : DeployedDesign or None
        The search over the deployed loop's composed certificate, with ``synthesis = "deployed"``.
    reasons : tuple of Reason
        Why there are no gains (empty when there are): the Theorem 1 design's (part ``theorem1``)
        or the robust design's (part ``robust``).
    mission : MissionReference
        The configured centre path.
    tube : ReferenceTube
        Sound bounds of the desired motion for all time: the mission's tube in the inertial
        frame (every vehicle moves as the centre), every vehicle's own tube in the path frame.
    offsets : ndarray, shape (N, 2)
        Vehicle offsets from the formation centre (m), in the configured frame.
    fit : ReferenceFit
        Per-vehicle verdict on the desired motion at zero error (binding vehicle and turn,
        smallest turn radius that fits), :func:`~auv_hinf.mission.fit.reference_fit`.
    """

    config: FormationConfig
    lam: float
    sigma: SigmaBounds
    gamma: float
    designs: dict[str, GainDesign | None]
    gains: Gains | None
    source: GainSource
    robust_design: RobustDesign | None
    reasons: tuple[Reason, ...]
    mission: MissionReference
    tube: ReferenceTube
    offsets: FloatArray
    fit: ReferenceFit
    deployed_design: DeployedDesign | None = None

    def require_gains(self) -> Gains:
        """The gains, or a :class:`~auv_hinf.exceptions.DesignError` saying why there are none."""
        if self.gains is None:
            raise DesignError("; ".join(r.message for r in self.reasons) or "the design gives no gains")
        return self.gains

    @property
    def box(self) -> ParameterBox:
        """The ``[uncertainty]`` box around the configured vehicle."""
        return ParameterBox.from_ranges(self.config.vehicle, self.config.uncertainty.box)

    @property
    def current(self) -> float:
        """The ``[disturbance]`` current bound (m/s, 0 when absent)."""
        return float(self.config.disturbance.current_speed or 0.0)

    @property
    def declared(self) -> bool:
        """A parameter box or a current is declared, or integral action (the robust certificate applies)."""
        return self.box.declared or self.current > 0.0 or self.config.integral

    def summary(self) -> dict[str, Any]:
        """The ``design`` object of ``auv-hinf certify --json``: method, structure, objective, value, gains."""
        cfg = self.config
        if self.source == "theorem1":
            method = f"theorem1-{cfg.method}"
            objective = "Theorem 1: the H-infinity bound gamma of the velocity loop (s)"
            value: float | None = self.gamma
        elif self.source == "deployed":
            method, objective = "deployed", DEPLOYED_OBJECTIVE
            value = None if self.deployed_design is None else self.deployed_design.value
        elif cfg.synthesis == "lmi":
            method, objective = "lmi", SYNTHESIS_OBJECTIVE
            value = None if self.robust_design is None else self.robust_design.bandwidth
        else:
            method = "bandwidth"
            objective = "the gentlest bandwidth (rad/s) of the family whose certificate covers the box with headroom"
            value = None if self.robust_design is None else self.robust_design.bandwidth
        return {
            "method": method,
            "structure": "scalar: alpha (1/s), k1 (1/s^2), "
            + ("ki (1/s^3, integral action), " if cfg.integral else "")
            + "k_psi (1/s^2, 1/s), the same for every vehicle",
            "objective": objective,
            "value": value,
            "reason": (
                self.deployed_design.binding
                if self.deployed_design is not None
                else None
                if self.robust_design is None
                else self.robust_design.reason
            ),
            "gains": None if self.gains is None else self.gains.to_dict(),
        }

    def fleet(self) -> FleetReference:
        """The raw (unshaped) fleet reference: the mission with the formation offsets in their frame."""
        return FleetReference(self.mission, self.offsets, None, self.config.frame)


def mission_reference(cfg: FormationConfig) -> MissionReference:
    """The configured mission (centre path).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its ``[reference]`` table).
    """
    return reference_from_dict(cfg.reference.kind, **cfg.reference.kwargs())


def formation_offsets(cfg: FormationConfig) -> FloatArray:
    """Vehicle offsets from the formation centre, shape ``(N, 2)`` (m), in O(N).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its Jacobi shape vectors and Jacobi convention).
    """
    rho = np.asarray(cfg.shape, dtype=float).reshape(cfg.n - 1, 2)
    return positions_from_jacobi(np.vstack([rho, np.zeros((1, 2))]), cfg.jacobi)


def raw_fleet(cfg: FormationConfig) -> FleetReference:
    """The raw (unshaped) fleet reference of ``cfg``: the mission with the formation offsets in their frame.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its ``[reference]``, Jacobi shape and ``[formation] frame``).
    """
    return FleetReference(mission_reference(cfg), formation_offsets(cfg), None, cfg.frame)


def initial_states(point: DesignPoint) -> FloatArray:
    """The configured initial states ``(N, 6)``; without ``[simulation] initial``, the fleet on its slots.

    The default start puts every vehicle exactly on its desired motion at ``t = 0`` along the
    raw mission (position on its slot, heading along the path, the path's speed as surge, the
    path's turn rate as yaw rate): zero tracking error, so the certificate covers it at every
    fleet size without a blended start, and ``certify`` and ``simulate`` judge the same start.

    Parameters
    ----------
    point : DesignPoint
        The design point (its configuration and fleet reference).
    """
    initial = point.config.simulation.initial
    if initial is not None:
        return np.asarray(initial, dtype=float)
    return slot_states(point.fleet())


def slot_states(fleet: FleetReference, current: tuple[float, float] = (0.0, 0.0)) -> FloatArray:
    """States ``(N, 6)`` ``[x, y, psi, u, v, r]`` with zero error against ``fleet`` at ``t = 0``.

    The body velocities are relative to the water, so a zero ground-velocity error needs
    ``[u, v] = R(psi)^T (p_d' - current)``.

    Parameters
    ----------
    fleet : FleetReference
        The desired motion.
    current : tuple of float
        The current (m/s, inertial frame).
    """
    m = fleet.motion(0.0)
    c, s = np.cos(m.psi), np.sin(m.psi)
    rel = m.v - np.asarray(current, dtype=float)
    u = c * rel[:, 0] + s * rel[:, 1]
    v = -s * rel[:, 0] + c * rel[:, 1]
    return np.column_stack([m.p, m.psi, u, v, m.r])


def design_point(cfg: FormationConfig, *, fallback: bool = True) -> DesignPoint:
    """The design of ``cfg`` (see the module docstring); cached on what it depends on.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    fallback : bool
        When no candidate of a deployed synthesis covers the declared world, search the gains that
        hold the implementation in still water (the gains that then run, from which the advice
        starts). ``False`` skips that search: the design is the same whenever a candidate covers,
        and otherwise runs the middle candidate; for a caller that only asks whether the design
        covers (a re-run of advice).

    Raises
    ------
    ConfigError
        If ``cfg`` is not a :class:`~auv_hinf.config.settings.FormationConfig`.
    DesignError
        If ``cfg.method`` is not a gain method.
    ParameterError
        If the mission reference is invalid.
    """
    require_config(cfg)
    if cfg.method not in GAIN_METHODS:
        raise DesignError(f"gain method must be one of {GAIN_METHODS}, got {cfg.method!r}")
    core = _design(_design_key(cfg), fallback)
    return replace(core, config=cfg)


def _design_key(cfg: FormationConfig) -> FormationConfig:
    """``cfg`` without what the design does not depend on (name, start, plant, current of the run,
    horizon, the implementation unless the gains are designed for it (``synthesis = "deployed"``;
    otherwise they are designed for the continuous law and the certificates say whether they
    survive the declared one), and the required separation, which only the separation part reads).
    With ``[guidance]`` the formation law does not run: its gains are Theorem 1's, not a robust or
    deployed design's (a search of many certificates for a law no vehicle runs)."""
    steered = cfg.guidance is not None
    return replace(
        cfg,
        name="design",
        simulation=SimulationConfig(),
        implementation=cfg.implementation if cfg.synthesis == "deployed" and not steered else Implementation(),
        min_separation=DEFAULT_MIN_SEPARATION,
        robust=cfg.robust and not steered,
        integral=cfg.integral and not steered,
        synthesis=DEFAULT_SYNTHESIS if steered else cfg.synthesis,
    )


def require_config(cfg: Any) -> FormationConfig:
    """``cfg`` when it is a configuration; else the package's :class:`~auv_hinf.exceptions.ConfigError`.

    Parameters
    ----------
    cfg : Any
        What the caller passed as a configuration.
    """
    if not isinstance(cfg, FormationConfig):
        raise ConfigError(
            f"expected a configuration (load_config(path) or preset_config(name)), got {type(cfg).__name__}"
        )
    return cfg


@lru_cache(maxsize=16)
def _design(cfg: FormationConfig, fallback: bool = True) -> DesignPoint:
    lam = cfg.lam if cfg.lam is not None else envelope_lambda(cfg.vehicle, cfg.envelope)
    sigma = vehicle_sigma(cfg.vehicle, cfg.envelope, lam, cfg.n)
    gamma = cfg.gamma if cfg.gamma is not None else 1.0 / sigma.upper
    reasons: list[Reason] = []
    designs: dict[str, GainDesign | None] = {}
    for m in GAIN_METHODS:
        try:
            designs[m] = design_alpha(lam, gamma, m)
        except DesignError as exc:
            designs[m] = None
            if m == cfg.method:
                reasons.append(Reason("theorem1", "design", str(exc)))
    mission = mission_reference(cfg)
    offsets = formation_offsets(cfg)
    tube = path_frame_tube(mission, offsets) if cfg.frame == "path" else mission_tube(mission)
    gains: Gains | None = None
    robust: RobustDesign | None = None
    deployed: DeployedDesign | None = None
    source: GainSource = ("deployed" if cfg.synthesis == "deployed" else "robust") if cfg.robust else "theorem1"
    if cfg.robust and cfg.synthesis == "deployed":
        limits = cfg.force_limits
        problem = deployed_problem(cfg, mission, tube, offsets, PLACEHOLDER_GAINS)
        deployed = synthesise_deployed(problem, None if limits is None else limits.admits, fallback=fallback)
        gains = deployed.gains
    elif cfg.robust:
        designer = synthesise_robust if cfg.synthesis == "lmi" else design_robust
        try:
            robust = designer(
                ParameterBox.from_ranges(cfg.vehicle, cfg.uncertainty.box),
                cfg.envelope,
                tube,
                float(cfg.disturbance.current_speed or 0.0),
                cfg.force_limits,
                progress=True,
                integral=cfg.integral,
            )
            gains = robust.gains
        except AuvHinfError as exc:
            reasons = [Reason("robust", "design", f"robust design failed: {exc}")]
    else:
        used = designs.get(cfg.method)
        if used is not None and math.isfinite(used.alpha):
            gains = Gains(used.alpha, cfg.k1, heading_gains(cfg.vehicle, cfg.heading_poles))
        elif used is not None:
            reasons.append(
                Reason(
                    "theorem1", "design", f"no finite gain for method {cfg.method!r} at lambda={lam:g}, gamma={gamma:g}"
                )
            )
    return DesignPoint(
        config=cfg,
        lam=lam,
        sigma=sigma,
        gamma=gamma,
        designs=designs,
        gains=gains,
        source=source,
        robust_design=robust,
        reasons=tuple(reasons),
        mission=mission,
        tube=tube,
        offsets=offsets,
        fit=reference_fit(mission, offsets, cfg.frame, cfg.envelope),
        deployed_design=deployed,
    )


__all__ = [
    "DesignPoint",
    "GainSource",
    "design_point",
    "formation_offsets",
    "initial_states",
    "mission_reference",
    "raw_fleet",
    "require_config",
    "slot_states",
]
