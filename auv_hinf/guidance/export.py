"""The guidance cascade as a python-control system: vehicle states in, propeller thrust and rudder out.

:func:`guidance_controller` wraps :func:`~auv_hinf.guidance.law.commands` for ``n`` vehicles
following the slots of a :class:`~auv_hinf.mission.fleet.FleetReference` as a
``control.NonlinearIOSystem``: its states are the ILOS integrators, its inputs each vehicle's
state and measured ground velocity, its outputs each vehicle's thrust and rudder, after the limits.
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.guidance.law import Commands, GuidanceConfig, SlotMotion, commands
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.vehicle import VehicleParams

#: Name of the exported system.
GUIDANCE_CONTROLLER_NAME = "guidance"
#: The per-vehicle inputs, in order: the state and the measured ground velocity (m, rad, m/s, rad/s).
VEHICLE_INPUTS = ("x", "y", "psi", "u", "v", "r", "vn", "ve")


def guidance_controller(
    gcfg: GuidanceConfig,
    model: VehicleParams,
    act: RudderActuation,
    ref: FleetReference,
    name: str = GUIDANCE_CONTROLLER_NAME,
) -> ct.NonlinearIOSystem:
    """The cascade of every vehicle of ``ref`` as one continuous-time ``nlsys``.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance and autopilot gains.
    model : VehicleParams
        The controller's model of the vehicle.
    act : RudderActuation
        The propeller and rudder (the limits are applied to the outputs).
    ref : FleetReference
        The slots' desired motion (``n`` vehicles).
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        ``n`` states ``y_i[k]`` (s, the ILOS integrators; zero and constant for LOS); ``8 n`` inputs
        :data:`VEHICLE_INPUTS` of each vehicle; ``2 n`` outputs ``thrust[k]`` (N) and ``rudder[k]``
        (rad).
    """
    n = ref.offsets.shape[0]

    def law(t: float, x: FloatArray, u: FloatArray) -> Commands:
        inputs = np.asarray(u, dtype=float).reshape(n, len(VEHICLE_INPUTS))
        (p, v, a, _), _ = ref.kinematics(np.asarray(float(t)))
        return commands(gcfg, model, act, inputs[:, :6], np.asarray(x, dtype=float), SlotMotion(p, v, a), inputs[:, 6:])

    def updfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        return np.asarray(law(t, x, u).integral_rate, dtype=float)

    def outfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        cmd = law(t, x, u)
        return np.column_stack([cmd.thrust, cmd.rudder]).ravel()

    return ct.nlsys(
        updfcn,
        outfcn,
        name=name,
        states=[f"y_i[{k}]" for k in range(n)],
        inputs=[f"{s}[{k}]" for k in range(n) for s in VEHICLE_INPUTS],
        outputs=[f"{s}[{k}]" for k in range(n) for s in ("thrust", "rudder")],
    )


__all__ = ["GUIDANCE_CONTROLLER_NAME", "VEHICLE_INPUTS", "guidance_controller"]
