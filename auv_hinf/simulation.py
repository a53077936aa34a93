"""Vectorised nonlinear closed-loop simulation of N vehicles (scipy ``solve_ivp``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from .control_law import FormationController
from .envelope import Envelope
from .exceptions import ParameterError, SolverError
from ._typing import FloatArray
from .vehicle import VehicleParams, rhs


#: Integration tolerances: shape errors of 1e-3 m on formations of 10-30 m need a
#: relative accuracy well below 1e-5; 1e-8 / 1e-8 keeps the integration error negligible.
RTOL, ATOL = 1e-8, 1e-8


@dataclass(frozen=True)
class Scenario:
    """A closed-loop simulation set-up.

    Attributes
    ----------
    controller : FormationController
    plant : VehicleParams
        The simulated vehicles (differs from ``controller.params`` for a mismatch study).
    initial : ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` per vehicle (m, m, rad, m/s, m/s, rad/s).
    horizon : float
        Simulated time, s.
    current : tuple of float
        Constant ocean current, inertial frame, m/s.
    envelope : Envelope, optional
        Certified envelope to check the trajectory against.
    samples : int
        Number of output samples.
    name : str
    """

    controller: FormationController
    plant: VehicleParams
    initial: FloatArray
    horizon: float
    current: tuple[float, float] = (0.0, 0.0)
    envelope: Envelope | None = None
    samples: int = 3001
    name: str = "scenario"

    def __post_init__(self) -> None:
        init = np.asarray(self.initial, dtype=float)
        n = self.controller.transform.n
        if init.shape != (n, 6) or not np.all(np.isfinite(init)):
            raise ParameterError(f"initial states must be a finite ({n}, 6) array, got shape {init.shape}")
        if not np.isfinite(self.horizon) or self.horizon <= 0:
            raise ParameterError(f"horizon must be > 0 s, got {self.horizon!r}")
        object.__setattr__(self, "initial", init)


def closed_loop_rhs(scn: Scenario, t: float, y: FloatArray) -> FloatArray:
    """Time derivative of the stacked state ``y`` (6N,), one vectorised call for all vehicles.

    Vehicle velocities are relative to the water; the current adds to the kinematics.
    """
    s = y.reshape(-1, 6)
    p_dot = ground_velocity(s, scn.current)
    tau, _ = scn.controller.forces(t, s, p_dot)
    d = rhs(scn.plant, s, tau)
    d[:, 0:2] += scn.current
    return d.ravel()


def ground_velocity(s: FloatArray, current: tuple[float, float]) -> FloatArray:
    """Inertial velocity ``R(psi) [u, v] + current`` of stacked states ``(N, 6)``, m/s."""
    c, sn = np.cos(s[:, 2]), np.sin(s[:, 2])
    return np.column_stack([c * s[:, 3] - sn * s[:, 4], sn * s[:, 3] + c * s[:, 4]]) + np.asarray(current)


@dataclass(frozen=True)
class SimulationResult:
    """Trajectories and metrics.

    Attributes
    ----------
    t : ndarray (T,)
        Time, s.
    states : ndarray (T, N, 6)
    forces : ndarray (T, N, 3)
        Applied thrust (after saturation), N and N m.
    jacobi : ndarray (T, N, 2)
        Jacobi coordinates (m).
    shape_error : ndarray (T,)
        ``||X_shape - rho_d||`` (m, Frobenius over the N-1 vectors).
    center_error : ndarray (T,)
        ``||q_c - q_cd||`` (m).
    desired_center : ndarray (T, 2)
    saturated : ndarray (T,) of bool
    scenario : Scenario
    """

    t: FloatArray
    states: FloatArray
    forces: FloatArray
    jacobi: FloatArray
    shape_error: FloatArray
    center_error: FloatArray
    desired_center: FloatArray
    saturated: NDArray[np.bool_]
    scenario: Scenario = field(repr=False)

    def error_at(self, time: float) -> tuple[float, float]:
        """Shape and centre error (m) at the sample nearest to ``time``."""
        k = int(np.argmin(np.abs(self.t - time)))
        return float(self.shape_error[k]), float(self.center_error[k])

    def envelope_check(self) -> tuple[bool | None, float | None]:
        """Whether ``(u, v, r)`` stayed in the scenario's envelope, and the first exit time (s)."""
        env = self.scenario.envelope
        if env is None:
            return None, None
        inside = env.contains(self.states[..., 3], self.states[..., 4], self.states[..., 5]).all(axis=1)
        if inside.all():
            return True, None
        return False, float(self.t[int(np.argmin(inside))])

    def summary(self) -> dict[str, Any]:
        """Metrics as a JSON-safe dictionary."""
        stayed, exit_time = self.envelope_check()
        return {
            "scenario": self.scenario.name,
            "n": int(self.states.shape[1]),
            "horizon": float(self.t[-1]),
            "final_shape_error": float(self.shape_error[-1]),
            "final_center_error": float(self.center_error[-1]),
            "rms_shape_error": float(np.sqrt(np.mean(self.shape_error**2))),
            "max_force": float(np.abs(self.forces[..., :2]).max()),
            "max_moment": float(np.abs(self.forces[..., 2]).max()),
            "max_speed": float(np.abs(self.states[..., 3]).max()),
            "max_sway": float(np.abs(self.states[..., 4]).max()),
            "max_yaw_rate": float(np.abs(self.states[..., 5]).max()),
            "final_sway": float(np.abs(self.states[-1, :, 4]).max()),
            "saturation_fraction": float(self.saturated.mean()),
            "stayed_in_envelope": stayed,
            "first_exit_time": exit_time,
        }

    def save_npz(self, path: str | Path) -> None:
        """Write time, states, forces and Jacobi coordinates to a ``.npz`` file."""
        np.savez_compressed(path, t=self.t, states=self.states, forces=self.forces, jacobi=self.jacobi)


def simulate(scn: Scenario, *, rtol: float = RTOL, atol: float = ATOL) -> SimulationResult:
    """Integrate the closed loop with RK45 and compute metrics.

    ``rtol``/``atol`` default to :data:`RTOL`/:data:`ATOL`; benchmarks loosen them to
    match a fixed-step peer's accuracy.
    """
    t_eval = np.linspace(0.0, scn.horizon, scn.samples)
    sol = solve_ivp(
        lambda t, y: closed_loop_rhs(scn, t, y), (0.0, scn.horizon), scn.initial.ravel(),
        method="RK45", t_eval=t_eval, rtol=rtol, atol=atol,
    )
    if not sol.success:
        raise SolverError(f"solve_ivp failed: {sol.message}")
    n = scn.controller.transform.n
    states = sol.y.T.reshape(-1, n, 6)
    ctrl = scn.controller
    forces = np.empty((len(sol.t), n, 3))
    sat = np.zeros(len(sol.t), dtype=bool)
    xd_c = np.empty((len(sol.t), 2))
    for k, tk in enumerate(sol.t):
        forces[k], sat[k] = ctrl.forces(tk, states[k], ground_velocity(states[k], scn.current))
        xd_c[k] = ctrl.trajectory(tk)[0]
    jac = np.einsum("jk,tkd->tjd", ctrl.transform.phi, states[..., 0:2])
    shape_err = np.linalg.norm((jac[:, :-1, :] - ctrl.shape).reshape(len(sol.t), -1), axis=1)
    center_err = np.linalg.norm(jac[:, -1, :] - xd_c, axis=1)
    return SimulationResult(
        t=sol.t, states=states, forces=forces, jacobi=jac, shape_error=shape_err,
        center_error=center_err, desired_center=xd_c, saturated=sat, scenario=scn,
    )
