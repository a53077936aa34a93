"""The certified formation controller and closed loop as python-control systems.

:func:`formation_controller` wraps the per-vehicle law (:class:`~auv_hinf.law.formation_law.VehicleLaw`)
as a static, time-varying ``control.nlsys``: inputs the measured fleet state, outputs the
body forces. :func:`fleet_closed_loop` closes it with N plants
(:func:`~auv_hinf.models.vehicle.vehicle_nlsys`) by ``control.interconnect``; the result has no
external inputs, its state is the stacked fleet state and its outputs repeat the state, so
``control.input_output_response`` simulates it and ``control.linearize`` linearises it.

Signal names (vehicle ``i = 0 .. N-1``):

* controller inputs and closed-loop outputs ``x[i], y[i], psi[i], u[i], v[i], r[i]``
  (m, m, rad, m/s, m/s, rad/s; ``u, v`` in the body frame);
* controller outputs ``tau_x[i], tau_y[i], tau_psi[i]`` (N, N, N m, body frame);
* plants ``auv{i}`` with the signal names of :func:`~auv_hinf.models.vehicle.vehicle_nlsys`;
  closed-loop states ``auv{i}_x, auv{i}_y, ...``, in the order of ``(N, 6).ravel()``.

The controller evaluates the law exactly as :func:`auv_hinf.simulation.engine.simulate` does for a
run without current: ground velocity ``R(psi) [u, v]``, desired motion ``reference.motion(t)``.
The default reference is the raw mission of the configuration (formation offsets around the
mission path, no shaped start), which is what the certificate's start region refers to.

The interconnection is a genuine ``control.interconnect`` of N + 1 subsystems rather than one
hand-stacked ``nlsys``: it is the python-control round trip the certificate promises. Its cost
is python-control's per-call overhead (the algebraic loop through the static controller is
resolved by fixed-point passes over all subsystems), a few milliseconds per right-hand side at
N = 5; use :func:`~auv_hinf.simulation.engine.simulate` for long or large runs.
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.law.formation_law import MotionSource, VehicleLaw
from auv_hinf.mission.fleet import Motion
from auv_hinf.models.vehicle import VehicleParams, ground_velocity, vehicle_nlsys

#: Names of one vehicle's state (and of the controller's measured signals).
STATE_NAMES = ("x", "y", "psi", "u", "v", "r")
#: Names of one vehicle's body forces.
FORCE_NAMES = ("tau_x", "tau_y", "tau_psi")
#: Names of one vehicle's integrator state (m s) when the law has integral action.
INTEGRATOR_NAMES = ("z_x", "z_y")
#: Name of the controller subsystem.
CONTROLLER_NAME = "formation_controller"


def fleet_signals(names: tuple[str, ...], n: int) -> list[str]:
    """``[f"{name}[{i}]" for i in range(n) for name in names]``: vehicle-major order.

    Parameters
    ----------
    names : tuple of str
        Signal names of one vehicle (e.g. :data:`STATE_NAMES`).
    n : int
        Number of vehicles.
    """
    return [f"{name}[{i}]" for i in range(n) for name in names]


def formation_controller(
    law: VehicleLaw, reference: MotionSource, n: int, name: str = CONTROLLER_NAME
) -> ct.NonlinearIOSystem:
    """Static nonlinear system ``tau = law.forces(states, R(psi)[u, v], reference.motion(t))``.

    Parameters
    ----------
    law : VehicleLaw
        Gains, model and thrust limit.
    reference : MotionSource
        Desired motion of the ``n`` vehicles; ``motion(t)`` at a scalar time must give
        ``(n, 2)`` vectors.
    n : int
        Number of vehicles.
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        No states (with integral action: ``2 n`` states ``z_x[i], z_y[i]``, m s, starting at
        zero, ``z' = p - p_d``); ``6 n`` inputs ``x[i] .. r[i]``; ``3 n`` outputs
        ``tau_x[i] .. tau_psi[i]`` (N, N, N m, body frame).
    """

    # python-control evaluates a static subsystem several times per right-hand side (fixed-point
    # passes over the algebraic loop), always at the same t: keep the last desired motion.
    last: dict[float, Motion] = {}

    def motion_at(t: float) -> Motion:
        tt = float(t)
        motion = last.get(tt)
        if motion is None:
            motion = reference.motion(tt)
            last.clear()
            last[tt] = motion
        return motion

    def outfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        states = np.asarray(u, dtype=float).reshape(n, 6)
        p_dot = ground_velocity(states, np.zeros(2))
        if law.gains.integral:  # the law reads the integrator after the measured state
            states = np.hstack([states, np.asarray(x, dtype=float).reshape(n, 2)])
        out: FloatArray = law.forces(states, p_dot, motion_at(t)).ravel()
        return out

    def updfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        states = np.asarray(u, dtype=float).reshape(n, 6)
        out: FloatArray = (states[:, 0:2] - motion_at(t).p).ravel()  # z' = p - p_d
        return out

    signals = {"inputs": fleet_signals(STATE_NAMES, n), "outputs": fleet_signals(FORCE_NAMES, n), "name": name}
    if law.gains.integral:
        return ct.nlsys(updfcn, outfcn, states=fleet_signals(INTEGRATOR_NAMES, n), **signals)
    return ct.nlsys(None, outfcn, **signals)


def fleet_closed_loop(
    law: VehicleLaw, reference: MotionSource, plant: VehicleParams, n: int, name: str = "formation_closed_loop"
) -> ct.NonlinearIOSystem:
    """``control.interconnect`` of ``n`` plants and the :func:`formation_controller`.

    Parameters
    ----------
    law, reference, n
        As in :func:`formation_controller`.
    plant : VehicleParams
        The simulated vehicles (the certificate assumes ``plant == law.params``).
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        ``6 n`` states (vehicle-major ``[x, y, psi, u, v, r]``; then the controller's ``2 n``
        integrator states with integral action), no inputs, outputs ``x[i] .. r[i]``.
    """
    ctrl = formation_controller(law, reference, n)
    plants = [vehicle_nlsys(plant, name=f"auv{i}") for i in range(n)]
    connections = []
    for i in range(n):
        connections += [[f"{CONTROLLER_NAME}.{s}[{i}]", f"auv{i}.{s}"] for s in STATE_NAMES]
        connections += [[f"auv{i}.{f}", f"{CONTROLLER_NAME}.{f}[{i}]"] for f in FORCE_NAMES]
    outlist = [f"auv{i}.{s}" for i in range(n) for s in STATE_NAMES]
    sys: ct.NonlinearIOSystem = ct.interconnect(
        [*plants, ctrl],
        connections=connections,
        inplist=[],
        outlist=outlist,
        outputs=fleet_signals(STATE_NAMES, n),
        name=name,
    )
    return sys


__all__ = [
    "CONTROLLER_NAME",
    "FORCE_NAMES",
    "INTEGRATOR_NAMES",
    "STATE_NAMES",
    "fleet_closed_loop",
    "fleet_signals",
    "formation_controller",
]
