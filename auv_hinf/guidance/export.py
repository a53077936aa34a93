"""The guidance cascade as a python-control system: vehicle states in, propeller thrust and rudder out.

:func:`guidance_controller` wraps :func:`~auv_hinf.guidance.law.commands` for ``n`` vehicles
following the slots of a :class:`~auv_hinf.mission.fleet.FleetReference` as a
``control.NonlinearIOSystem``: its states are the ILOS integrators, its inputs each vehicle's
state and measured ground velocity, its outputs each vehicle's thrust and rudder, after the limits.
:func:`sampled_guidance_controller` is the cascade as it runs and as its certificate covers it:
discrete time at the control period, the ILOS integrators advanced by the controller's own Euler
step, the delay a shift of whole samples.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import control as ct
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.guidance.law import Commands, GuidanceConfig, SlotMotion, commands
from auv_hinf.law.interconnect import delay_samples
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
    law = _fleet_law(gcfg, model, act, ref)

    def updfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        return np.asarray(law(t, x, u).integral_rate, dtype=float)

    def outfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        return _outputs(law(t, x, u))

    inputs, outputs = _signals(n)
    return ct.nlsys(updfcn, outfcn, name=name, states=[f"y_i[{k}]" for k in range(n)], inputs=inputs, outputs=outputs)


def sampled_guidance_controller(
    gcfg: GuidanceConfig,
    model: VehicleParams,
    act: RudderActuation,
    ref: FleetReference,
    sample_time: float,
    delay: float = 0.0,
    name: str = GUIDANCE_CONTROLLER_NAME,
) -> ct.NonlinearIOSystem:
    """The cascade of every vehicle of ``ref`` as it runs: a discrete-time ``nlsys`` with ``dt = sample_time``.

    At step ``k`` (time ``t_k = k h``) the output is :func:`~auv_hinf.guidance.law.commands` on the
    input of step ``k - m`` against the slots at ``max(t_k - m h, 0)``, ``m = floor(delay / h)``
    (:func:`~auv_hinf.law.interconnect.delay_samples`), and the ILOS integrators advance by ``h`` times
    that command's rate: the controller's own Euler step, which
    :func:`~auv_hinf.guidance.simulation.simulate_guidance` runs and the cascade's certificate covers.
    The ``m`` inputs before the current one are states, oldest first; for ``k < m`` they are the
    initial ones, so ``X0`` = the integrators, then ``m`` copies of the input at ``t = 0``, reproduces a
    run that measures the start until ``t = d``. Start the integrators at
    :func:`~auv_hinf.guidance.law.integral_start` of the first measurement, as a run does. A fractional
    delay is rounded down to whole samples (simulate it with ``simulate``).

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
    sample_time : float
        The control period ``h`` (s, > 0).
    delay : float
        The measurement's delay (s, >= 0).
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        ``dt = h``; states ``y_i[k]`` (s) then ``{input}@k-j`` for ``j = m .. 1``; ``8 n`` inputs
        :data:`VEHICLE_INPUTS` of each vehicle; ``2 n`` outputs ``thrust[k]`` (N) and ``rudder[k]`` (rad).
    """
    n = ref.offsets.shape[0]
    m = delay_samples(sample_time, delay)
    h, width = float(sample_time), n * len(VEHICLE_INPUTS)
    fleet_law = _fleet_law(gcfg, model, act, ref)

    def law(t: float, x: FloatArray, u: FloatArray) -> Commands:
        x = np.asarray(x, dtype=float)  # the measurement of step k - m, against the slots at its time
        return fleet_law(max(float(t) - m * h, 0.0), x[:n], x[n : n + width] if m else u)

    def updfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        x = np.asarray(x, dtype=float)
        integral = x[:n] + h * np.asarray(law(t, x, u).integral_rate, dtype=float)
        return np.concatenate([integral, x[n + width :], np.asarray(u, dtype=float)]) if m else integral

    def outfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        return _outputs(law(t, x, u))

    inputs, outputs = _signals(n)
    states = [f"y_i[{k}]" for k in range(n)] + [f"{s}@k-{j}" for j in range(m, 0, -1) for s in inputs]
    return ct.nlsys(updfcn, outfcn, name=name, dt=h, states=states, inputs=inputs, outputs=outputs)


def _fleet_law(
    gcfg: GuidanceConfig, model: VehicleParams, act: RudderActuation, ref: FleetReference
) -> Callable[[float, FloatArray, FloatArray], Commands]:
    """The cascade at slot time ``t`` on the ILOS integrators and the measured inputs (:data:`VEHICLE_INPUTS`)."""
    n = ref.offsets.shape[0]

    def law(t: float, integrators: FloatArray, inputs: FloatArray) -> Commands:
        measured = np.asarray(inputs, dtype=float).reshape(n, len(VEHICLE_INPUTS))
        (p, v, a, _), _ = ref.kinematics(np.asarray(float(t)))
        slots = SlotMotion(p, v, a)
        return commands(gcfg, model, act, measured[:, :6], np.asarray(integrators, dtype=float), slots, measured[:, 6:])

    return law


def _outputs(cmd: Commands) -> FloatArray:
    """The outputs ``thrust[k], rudder[k]`` (N, rad) of a command, vehicle by vehicle."""
    out: FloatArray = np.column_stack([cmd.thrust, cmd.rudder]).ravel()
    return out


def _signals(n: int) -> tuple[list[str], list[str]]:
    """The input and output names of ``n`` vehicles' cascade."""
    inputs = [f"{s}[{k}]" for k in range(n) for s in VEHICLE_INPUTS]
    return inputs, [f"{s}[{k}]" for k in range(n) for s in ("thrust", "rudder")]


__all__ = ["GUIDANCE_CONTROLLER_NAME", "VEHICLE_INPUTS", "guidance_controller", "sampled_guidance_controller"]
