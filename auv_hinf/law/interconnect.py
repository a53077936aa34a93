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

:func:`sampled_formation_controller` is the law as it runs at a sample time: a discrete-time
``nlsys`` (``dt = sample_time``) whose output at step ``k`` is the law on the measurement of step
``k - m``, ``m`` the delay in whole samples, the convention of
:mod:`auv_hinf.implementation.sampled_loop` for a delay that is a multiple of the sample time.

The interconnection is a genuine ``control.interconnect`` of N + 1 subsystems rather than one
hand-stacked ``nlsys``: it is the python-control round trip the certificate promises. Its cost
is python-control's per-call overhead (the algebraic loop through the static controller is
resolved by fixed-point passes over all subsystems), a few milliseconds per right-hand side at
N = 5; use :func:`~auv_hinf.simulation.engine.simulate` for long or large runs.
"""

from __future__ import annotations

import math
from typing import Any

import control as ct
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError
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
#: A delay within this many seconds of a whole number of samples is that number: ``k h`` and a
#: declared delay differ by round-off only (the sampled loop snaps its instants likewise).
WHOLE_SAMPLE_TOLERANCE = 1e-9


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


def delay_samples(sample_time: float, delay: float) -> int:
    """Whole samples ``m = floor(delay / sample_time)`` of a delay (up to :data:`WHOLE_SAMPLE_TOLERANCE`).

    Parameters
    ----------
    sample_time : float
        Sample time (s, > 0).
    delay : float
        Delay (s, >= 0).

    Returns
    -------
    int
        The number of whole samples the delay spans; a fractional rest is dropped.
    """
    if not sample_time > 0.0 or not delay >= 0.0:
        raise ParameterError(f"need sample_time > 0 and delay >= 0 (s), got {sample_time!r}, {delay!r}")
    return math.floor((delay + WHOLE_SAMPLE_TOLERANCE) / sample_time)


def sampled_formation_controller(
    law: VehicleLaw,
    reference: MotionSource,
    n: int,
    sample_time: float,
    delay: float = 0.0,
    name: str = CONTROLLER_NAME,
) -> ct.NonlinearIOSystem:
    """The law as it runs at ``sample_time``: a discrete-time ``nlsys`` with ``dt = sample_time``.

    At step ``k`` (time ``t_k = k h``) the output is the law of :func:`formation_controller` on the
    input of step ``k - m`` against the desired motion at ``t_{k-m}``, with
    ``m = floor(delay / h)`` (:func:`delay_samples`): the delay as a shift of whole samples. Its
    states are the ``m`` inputs before the current one, oldest first; for ``k < m`` they are the
    initial state, so ``X0 = m`` copies of the state at ``t = 0`` reproduces the sampled loop,
    which measures ``max(t_k - d, 0)``, and the desired motion is taken at ``max(t_k - m h, 0)``.
    The output is held by whatever samples the system (a zero-order hold in the sampled loop).

    A fractional delay (``delay`` not a multiple of ``h``) is rounded down to whole samples: the
    system is then the law delayed by ``m h < delay``, which the certificate covers when it declares
    ``varying_delay`` (any delay in ``[0, delay]``) and does not reproduce a fixed fractional delay,
    whose measurements fall between the samples; simulate that with the sampled loop
    (:func:`auv_hinf.simulation.engine.simulate`).

    Parameters
    ----------
    law : VehicleLaw
        Gains, model and saturation; without integral action (it is certified continuous only).
    reference : MotionSource
        Desired motion of the ``n`` vehicles.
    n : int
        Number of vehicles.
    sample_time : float
        Sample time ``h`` (s, > 0).
    delay : float
        Lumped delay (s, >= 0).
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        ``dt = h``; inputs ``x[i] .. r[i]``, outputs ``tau_x[i] .. tau_psi[i]`` (N, N, N m), states
        ``x[i]@k-j .. r[i]@k-j`` for ``j = m .. 1`` (none without a delay of a whole sample).
    """
    if law.gains.integral:
        raise ParameterError("integral action runs with the continuous law only: no sampled controller for it")
    m = delay_samples(sample_time, delay)
    h, width = float(sample_time), 6 * n

    def outfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        measured = np.asarray(x[:width] if m else u, dtype=float).reshape(n, 6)
        at = max(float(t) - m * h, 0.0)
        out: FloatArray = law.forces(measured, ground_velocity(measured, np.zeros(2)), reference.motion(at)).ravel()
        return out

    def updfcn(t: float, x: FloatArray, u: FloatArray, params: dict[str, Any] | None) -> FloatArray:
        out: FloatArray = np.concatenate([np.asarray(x, dtype=float)[width:], np.asarray(u, dtype=float)])
        return out

    signals = {"inputs": fleet_signals(STATE_NAMES, n), "outputs": fleet_signals(FORCE_NAMES, n), "name": name}
    if m == 0:
        return ct.nlsys(None, outfcn, dt=h, **signals)
    states = [f"{s}@k-{j}" for j in range(m, 0, -1) for s in fleet_signals(STATE_NAMES, n)]
    return ct.nlsys(updfcn, outfcn, states=states, dt=h, **signals)


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
    "WHOLE_SAMPLE_TOLERANCE",
    "delay_samples",
    "fleet_closed_loop",
    "fleet_signals",
    "formation_controller",
    "sampled_formation_controller",
]
