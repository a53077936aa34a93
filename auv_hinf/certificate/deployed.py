"""A configuration's deployed loop as a composed-certificate problem.

:func:`deployed_problem` gathers what :func:`~auv_hinf.composed.certificate.certify_deployed`
needs from a configuration: the controller's model with the ``[uncertainty]`` box and the
``[disturbance]`` current, the bounds of every vehicle's desired motion (the mission's tube and
its jerks), the envelope, the ``[implementation]`` and the gains. The design
(:mod:`auv_hinf.certificate.design_point`, gains synthesised for the deployed loop) and the
composed certificate part (:mod:`auv_hinf.certificate.parts.composed`) both build it here.
"""

from __future__ import annotations

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.composed.certificate import DeployedProblem
from auv_hinf.composed.loops import Errors, MissionBounds, Plant
from auv_hinf.config.settings import FormationConfig
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.paths import MissionReference, course_jerk_bound
from auv_hinf.robust.box import ParameterBox

#: The start of a design: every vehicle on its slot (the composed part certifies the configured start).
ON_SLOT = Errors(0.0, 0.0, 0.0, 0.0)


def mission_jerks(mission: MissionReference, offsets: FloatArray, frame: str) -> tuple[float, float]:
    """Bounds of every vehicle's ``|p_d'''|`` (m/s^3) and of ``|psi_d'''|`` (rad/s^3) along the raw mission.

    ``psi_d`` is the course ``chi`` in both frames (:func:`~auv_hinf.mission.paths.course_jerk_bound`).
    In the path frame ``p_i = q + R(chi) d_i`` adds ``|d_i| (|chi'''| + 3 |chi'| |chi''| + |chi'|^3)``
    to the path's jerk.

    Parameters
    ----------
    mission : MissionReference
        The centre path.
    offsets : ndarray, shape (N, 2)
        The formation offsets (m).
    frame : {"inertial", "path"}
        The offsets' frame.
    """
    b = mission.bounds()
    yaw_jerk = course_jerk_bound(b.speed_min, b.accel_max, b.jerk_max, b.snap_max)
    jerk = b.jerk_max
    if frame == "path":
        d = float(np.hypot(offsets[:, 0], offsets[:, 1]).max())
        rate = max(abs(b.turn_rate_min), abs(b.turn_rate_max))
        jerk += d * (yaw_jerk + 3.0 * rate * b.turn_accel_max + rate**3)
    return jerk, yaw_jerk


def deployed_plant(cfg: FormationConfig) -> Plant:
    """The controller's model, the declared box and the declared current (constant when no rate is declared).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    """
    return Plant(
        model=cfg.vehicle,
        box=ParameterBox.from_ranges(cfg.vehicle, cfg.uncertainty.box),
        current=float(cfg.disturbance.current_speed or 0.0),
        current_rate=float(cfg.disturbance.current_rate or 0.0),
    )


def deployed_problem(
    cfg: FormationConfig,
    mission: MissionReference,
    tube: ReferenceTube,
    offsets: FloatArray,
    gains: Gains,
    start: Errors = ON_SLOT,
) -> DeployedProblem:
    """The composed-certificate problem of ``cfg``'s deployed loop with ``gains`` from ``start``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (a sampled ``[implementation]``).
    mission : MissionReference
        The centre path.
    tube : ReferenceTube
        Bounds of every vehicle's desired motion per time cell.
    offsets : ndarray, shape (N, 2)
        The formation offsets (m).
    gains : Gains
        The law's gains.
    start : Errors
        Bounds of the errors at ``t = 0`` (default: on the slots).
    """
    jerk, yaw_jerk = mission_jerks(mission, offsets, cfg.frame)
    return DeployedProblem(
        plant=deployed_plant(cfg),
        mission=MissionBounds.of(tube, jerk, yaw_jerk),
        envelope=cfg.envelope,
        implementation=cfg.implementation,
        gains=gains,
        start=start,
    )


__all__ = ["ON_SLOT", "deployed_plant", "deployed_problem", "mission_jerks"]
