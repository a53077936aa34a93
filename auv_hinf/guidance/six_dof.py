"""The guidance cascade on the 6-DOF REMUS 100: how far the 3-DOF results carry to a richer model.

The cascade of :mod:`auv_hinf.guidance.law` steers each vehicle in the horizontal plane from
what it measures there (``x, y, psi, u, v, r`` and the ground velocity) with its propeller and
rudder, exactly as on the 3-DOF model. The plant is :mod:`auv_hinf.models.remus6dof`: it heaves,
rolls and pitches, its sway and yaw are coupled, and the propeller's torque rolls it. Its depth
and pitch are held by the vehicle's own autopilot, :class:`DepthAutopilot`, on the stern
planes: a PI law on the depth error sets the pitch, and a critically damped pitch loop with
Prestero's stern-plane moment sets the planes, clipped to the fins' limit. The depth autopilot
runs continuously inside the vehicle (its integral is a state of the plant); the horizontal
cascade is sampled and held at :data:`~auv_hinf.guidance.simulation.STEP`, as on the 3-DOF model.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.exceptions import ParameterError, require_finite, require_positive
from auv_hinf.guidance.law import Commands, GuidanceConfig
from auv_hinf.guidance.simulation import EXACT, STEP, GuidanceRun, Navigation, run_cascade
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models import remus6dof as six
from auv_hinf.models.vehicle import VehicleParams

#: Surge speed (m/s) below which the stern-plane law stops dividing by ``u^2`` (the fins lose
#: their grip at low speed; the REMUS cruises at 1.5 m/s).
MIN_PLANE_SPEED = 0.2


@dataclass(frozen=True)
class DepthAutopilot:
    """Depth and pitch held by the stern planes.

    ``theta_d = clip(k_z (z - z_d) + k_i int (z - z_d) dt, +-max_pitch)`` (nose down to go
    deeper: ``z`` is positive down), and the planes ``delta_s = (I_yy - M_qdot) (-w^2 (theta -
    theta_d) - 2 w q) / (M_uuds u^2)``, clipped to ``+-stern_max``.

    Attributes
    ----------
    depth : float
        Commanded depth ``z_d`` (m, positive down).
    depth_gain : float
        ``k_z`` (rad/m).
    depth_integral : float
        ``k_i`` (rad/(m s)): removes the depth offset of the vehicle's positive buoyancy.
    max_pitch : float
        Largest commanded pitch (rad).
    pitch_bandwidth : float
        ``w`` (rad/s) of the pitch loop.
    stern_max : float
        Stern-plane limit (rad): Prestero's fin limit, the rudder's.
    """

    depth: float = 5.0
    depth_gain: float = 0.2
    depth_integral: float = 0.01
    max_pitch: float = 0.35
    pitch_bandwidth: float = 1.0
    stern_max: float = 0.2374

    def __post_init__(self) -> None:
        for name in ("depth_gain", "max_pitch", "pitch_bandwidth", "stern_max"):
            require_positive(name, getattr(self, name))
        require_finite("depth", self.depth)
        if require_finite("depth_integral", self.depth_integral) < 0.0:
            raise ParameterError(f"depth_integral must be >= 0, got {self.depth_integral!r}")

    def stern(self, c: six.Remus6Dof, state: FloatArray, integral: FloatArray) -> FloatArray:
        """Stern-plane deflection (rad) for the states ``(N, 12)`` and depth integrals ``(N,)`` (m s).

        Parameters
        ----------
        c : Remus6Dof
            The coefficients the autopilot uses.
        state : ndarray, shape (N, 12)
            The states.
        integral : ndarray, shape (N,)
            The integrals of the depth error (m s).
        """
        ez = state[:, six.Z] - self.depth
        theta_d = np.clip(self.depth_gain * ez + self.depth_integral * integral, -self.max_pitch, self.max_pitch)
        w = self.pitch_bandwidth
        accel = -w * w * (state[:, six.THETA] - theta_d) - 2.0 * w * state[:, six.Q]
        u = np.maximum(state[:, six.U], MIN_PLANE_SPEED)
        raw = (c.i_yy - c.m_qdot) * accel / (c.m_uuds * u * u)
        return np.asarray(np.clip(raw, -self.stern_max, self.stern_max), dtype=float)


@dataclass(frozen=True)
class SixDofPlant:
    """A fleet of 6-DOF REMUS 100 with their depth autopilots, for :func:`~auv_hinf.guidance.simulation.run_cascade`.

    The full state of a vehicle is the 12 states of :mod:`~auv_hinf.models.remus6dof` and the
    integral of its depth error (m s).

    Attributes
    ----------
    coefficients : Remus6Dof
        The true vehicle.
    current : ndarray, shape (2,)
        Constant current (m/s, north and east).
    depth : DepthAutopilot
        The depth and pitch autopilot.
    """

    coefficients: six.Remus6Dof
    current: FloatArray
    depth: DepthAutopilot = field(default_factory=DepthAutopilot)

    @cached_property
    def inverse_mass(self) -> FloatArray:
        """``inv(mass_matrix(coefficients))``: computed once per plant, not at every derivative."""
        return np.linalg.inv(six.mass_matrix(self.coefficients))

    def start(self, horizontal: FloatArray) -> FloatArray:
        """Level, at the commanded depth, with the horizontal states ``(N, 6)``.

        Parameters
        ----------
        horizontal : ndarray, shape (N, 6)
            ``[x, y, psi, u, v, r]`` per vehicle.
        """
        n = horizontal.shape[0]
        x = np.zeros((n, six.STATES + 1))
        x[:, [six.X, six.Y, six.PSI, six.U, six.V, six.R]] = horizontal
        x[:, six.Z] = self.depth.depth
        return x

    def horizontal(self, state: FloatArray) -> FloatArray:
        """``[x, y, psi, u, v, r]`` of every vehicle.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        return state[:, [six.X, six.Y, six.PSI, six.U, six.V, six.R]]

    def ground(self, state: FloatArray) -> FloatArray:
        """The horizontal ground velocity (m/s): the body velocity turned to the earth, plus the current.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        return six.kinematics(state[:, : six.STATES], self.current)[:, :2]

    def derivative(self, state: FloatArray, cmd: Commands) -> FloatArray:
        """The 6-DOF derivative under the delivered thrust and rudder, with the depth autopilot's planes.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        cmd : Commands
            The cascade's commands; their delivered thrust and rudder act.
        """
        body = state[:, : six.STATES]
        stern = self.depth.stern(self.coefficients, body, state[:, six.STATES])
        d = six.derivative(self.coefficients, body, cmd.thrust, cmd.rudder, stern, self.current, self.inverse_mass)
        return np.concatenate([d, (body[:, six.Z] - self.depth.depth)[:, None]], axis=1)

    def vertical(self, state: FloatArray) -> FloatArray | None:
        """``[z, phi, theta]`` of every vehicle (m, rad, rad).

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        return state[:, [six.Z, six.PHI, six.THETA]]


def simulate_guidance_6dof(
    gcfg: GuidanceConfig,
    model: VehicleParams,
    act: RudderActuation,
    ref: FleetReference,
    horizon: float,
    current: tuple[float, float] = (0.0, 0.0),
    coefficients: six.Remus6Dof | None = None,
    depth: DepthAutopilot | None = None,
    step: float = STEP,
    navigation: Navigation = EXACT,
) -> GuidanceRun:
    """Run the cascade, designed on the 3-DOF ``model``, on a fleet of 6-DOF REMUS 100.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance and autopilot gains.
    model : VehicleParams
        The 3-DOF model the cascade uses.
    act : RudderActuation
        The propeller and rudder figures the cascade uses, and the limits.
    ref : FleetReference
        The slots' desired motion.
    horizon : float
        Length of the run (s, > 0).
    current : tuple of float
        Constant current (m/s, inertial).
    coefficients : Remus6Dof, optional
        The true vehicle (default: Prestero's REMUS 100).
    depth : DepthAutopilot, optional
        The depth autopilot (default: :class:`DepthAutopilot`, its planes at the rudder's limit).
    step : float
        Control and integration step (s).
    navigation : Navigation
        The measurement's delay and noise (default exact and undelayed).

    Returns
    -------
    GuidanceRun
        The run; its ``states`` are the horizontal states and ``vertical`` the depth, roll and pitch.
    """
    plant = SixDofPlant(
        six.Remus6Dof() if coefficients is None else coefficients,
        np.asarray(current, dtype=float),
        DepthAutopilot(stern_max=act.rudder_max) if depth is None else depth,
    )
    return run_cascade(gcfg, model, act, ref, horizon, plant, None, step, navigation)


__all__ = ["MIN_PLANE_SPEED", "DepthAutopilot", "SixDofPlant", "simulate_guidance_6dof"]
