"""Formation control law (Yang & Zhang, eqs. 26-28, 39, 41) in its O(N) per-vehicle form.

With scalar gains ``alpha I`` and ``K1 = k1 I`` and ``Phi 1 = e_N`` (the centroid row),
the law of eqs. (39) and (41) reduces exactly to one law per vehicle in vehicle
coordinates (inertial frame)::

    w_i = -alpha (p_i' - p_id') - k1 (p_i - p_id) - G_i p_id' + p_id'',   tau_xy,i = M1 R(psi_i)^T w_i

where ``p_id`` is vehicle i's desired position and ``G_i = R B(u, v, r) R^T`` (eq. 8) is
evaluated at the measured state. :class:`VehicleLaw` applies it with no N x N matrix;
:class:`FormationController` keeps the paper's Jacobi form (dense ``Phi``) as a reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray, OrientationLaw
from auv_hinf.exceptions import DesignError, ParameterError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import Motion, rigid_motion, wrap_angle
from auv_hinf.mission.paths import MissionReference, heading_from_velocity
from auv_hinf.models.jacobi import JacobiTransform
from auv_hinf.models.vehicle import VehicleParams, inertial_block, rotation
from auv_hinf.numerics.arrays import stack_last


@runtime_checkable
class MotionSource(Protocol):
    """Anything that gives the desired motion of every vehicle.

    ``motion(t)`` with a scalar ``t`` (s) returns a :class:`~auv_hinf.mission.fleet.Motion`
    with vectors of shape ``(N, 2)`` and scalars of shape ``(N,)``; with ``t`` of shape
    ``(S,)`` it returns ``(S, N, 2)`` and ``(S, N)``: row ``s`` is the motion at ``t[s]``
    (for a batch of scenarios, row ``s`` belongs to scenario ``s``).
    """

    def motion(self, t: float | FloatArray) -> Motion:
        """Desired motion at time(s) ``t`` (s).

        Parameters
        ----------
        t : float or ndarray, shape (S,)
            Time (s), or one time per row.
        """
        ...


@runtime_checkable
class VehicleMotionSource(MotionSource, Protocol):
    """A :class:`MotionSource` that can also evaluate each vehicle at its own time.

    ``motion_per_vehicle(t)`` takes ``t`` of shape ``(..., N)`` (s) and returns vectors
    ``(..., N, 2)`` and scalars ``(..., N)``, vehicle ``i`` evaluated at ``t[..., i]``.
    Needed to integrate a decoupled fleet with one step size per vehicle.
    """

    def motion_per_vehicle(self, t: FloatArray) -> Motion:
        """Desired motion of vehicle ``i`` at time ``t[..., i]`` (s).

        Parameters
        ----------
        t : ndarray, shape (..., N)
            Time of each vehicle (s).
        """
        ...


@dataclass(frozen=True)
class RigidReference:
    """Vehicles on fixed offsets around a mission path, heading along the path's velocity.

    ``p_id(t) = offsets_i + q(t)``, ``psi_d = atan2(q')``: the same motion as an unshaped
    :class:`~auv_hinf.mission.fleet.FleetReference`, and also a :class:`VehicleMotionSource`
    (each vehicle at its own time), which the decoupled per-vehicle integration needs.

    Parameters
    ----------
    trajectory : MissionReference
        Centre path (inertial, m), e.g. :class:`~auv_hinf.mission.paths.SineReference`.
    offsets : ndarray, shape (N, 2)
        Desired vehicle positions relative to the centre (inertial, m).
    """

    trajectory: MissionReference
    offsets: FloatArray

    def __post_init__(self) -> None:
        off = np.asarray(self.offsets, dtype=float)
        if off.ndim != 2 or off.shape[1] != 2 or not np.all(np.isfinite(off)):
            raise ParameterError(f"offsets must be a finite (N, 2) array, got shape {off.shape}")
        object.__setattr__(self, "offsets", off)

    def motion(self, t: float | FloatArray) -> Motion:
        """Motion at ``t`` (scalar or shape ``(S,)``), all vehicles at the same time.

        Parameters
        ----------
        t : float or ndarray, shape (S,)
            Time (s), or one time per row.
        """
        q, qd, qdd, qddd = self.trajectory(np.asarray(t, dtype=float))
        return rigid_motion(self.offsets, q, qd, qdd, *heading_from_velocity(qd, qdd, qddd))

    def motion_per_vehicle(self, t: FloatArray) -> Motion:
        """Motion of vehicle ``i`` at ``t[..., i]`` (s).

        Parameters
        ----------
        t : ndarray, shape (..., N)
            Time of each vehicle (s).
        """
        q, qd, qdd, qddd = self.trajectory(np.asarray(t, dtype=float))
        psi, r, r_dot = heading_from_velocity(qd, qdd, qddd)
        return Motion(p=q + self.offsets, v=qd, a=qdd, psi=psi, r=r, r_dot=r_dot)


#: State size per vehicle with integral action: ``[x, y, psi, u, v, r, z_x, z_y]``.
INTEGRAL_WIDTH = 8


def heading_torque(
    params: VehicleParams,
    k_psi: tuple[float, float],
    orientation: OrientationLaw,
    states: FloatArray,
    psi_d: FloatArray,
    r_d: FloatArray,
    r_dot_d: FloatArray,
) -> FloatArray:
    """Yaw moment of eqs. (26)-(28) (N m), shape ``states.shape[:-1]``.

    ``"corrected"``: ``V = psi_d'' + (d33/m33) psi_d' - k1 e - k2 e'``;
    ``"printed"``: ``V = psi_d' + (d33/m33) psi_d - k1 e - k2 e'``, with
    ``e = wrap(psi - psi_d)``, ``e' = r - psi_d'`` and ``d33 = d33(r)`` at the measured rate.

    Parameters
    ----------
    params : VehicleParams
        The controller's model of the vehicle.
    k_psi : tuple of float
        Heading gains ``(k1psi, k2psi)`` (1/s^2, 1/s).
    orientation : {"corrected", "printed"}
        Which heading law (above).
    states : ndarray, shape (..., 6) or wider
        Measured ``[x, y, psi, u, v, r, ...]`` (m, m, rad, m/s, m/s, rad/s).
    psi_d : ndarray
        Desired heading (rad), broadcasting against ``states.shape[:-1]``.
    r_d : ndarray
        Desired yaw rate (rad/s).
    r_dot_d : ndarray
        Desired yaw acceleration (rad/s^2).
    """
    psi, u, v, r = states[..., 2], states[..., 3], states[..., 4], states[..., 5]
    d33_over_m = (params.d33_lin + params.d33_quad * np.abs(r)) / params.m33
    e = wrap_angle(psi - psi_d)
    e_dot = r - r_d
    k1p, k2p = k_psi
    if orientation == "corrected":
        big_v = r_dot_d + d33_over_m * r_d - k1p * e - k2p * e_dot
    else:
        big_v = r_d + d33_over_m * psi_d - k1p * e - k2p * e_dot
    result: FloatArray = params.m33 * big_v - (params.m11 - params.m22) * u * v  # eq. (26)
    return result


def check_orientation(orientation: str) -> None:
    """Validate the heading-law name shared by both law forms.

    Parameters
    ----------
    orientation : str
        ``"corrected"`` or ``"printed"``; anything else raises :class:`DesignError`.
    """
    if orientation not in ("corrected", "printed"):
        raise DesignError(f"orientation must be 'corrected' or 'printed', got {orientation!r}")


@runtime_checkable
class ForceLimits(Protocol):
    """What the law needs of the vehicles' actuators: the forces they deliver for a command.

    :class:`~auv_hinf.actuation.limits.Actuators` is the toolbox's implementation (per-channel
    limits, or a thruster allocation polytope); the law depends on this protocol only.
    """

    def saturate(self, tau: FloatArray, surge: FloatArray | None = None) -> tuple[FloatArray, NDArray[np.bool_]]:
        """The delivered forces for commands ``tau (..., 3)`` (N, N, N m), and where a limit is active.

        Parameters
        ----------
        tau : ndarray, shape (..., 3)
            Commanded ``[tau_x, tau_y, tau_psi]`` (N, N, N m, body frame).
        surge : ndarray, optional
            The vehicles' surge speeds ``u`` (m/s), shape ``tau.shape[:-1]``: a rudder's forces
            depend on them (thrusters' do not).
        """
        ...

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe description of the limits (for run reports)."""
        ...


def saturate(
    tau: FloatArray, actuators: ForceLimits | None, surge: FloatArray | None = None
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The forces ``actuators`` deliver for commands ``tau (..., 3)`` (N, N, N m); also the active flag.

    Without declared actuators nothing saturates.

    Parameters
    ----------
    tau : ndarray, shape (..., 3)
        Commanded ``[tau_x, tau_y, tau_psi]`` (N, N, N m, body frame).
    actuators : ForceLimits or None
        The vehicles' actuators; None for unlimited.
    surge : ndarray, optional
        The vehicles' surge speeds ``u`` (m/s), shape ``tau.shape[:-1]`` (a rudder needs them).
    """
    if actuators is None:
        return tau, np.zeros(tau.shape[:-1], dtype=bool)
    return actuators.saturate(tau, surge)


@dataclass(frozen=True)
class VehicleLaw:
    """The per-vehicle form of the Yang & Zhang law: O(N), vectorised over leading axes.

    Parameters
    ----------
    params : VehicleParams
        The controller's model of the vehicles (may differ from the plant).
    gains : Gains
        ``alpha`` (1/s), ``k1`` (1/s^2) and the heading gains ``k_psi`` (1/s^2, 1/s).
    orientation : {"corrected", "printed"}
        Heading law, see :func:`heading_torque`.
    actuators : ForceLimits, optional
        What the vehicles can push (an :class:`~auv_hinf.actuation.limits.Actuators`); commands beyond
        it saturate (none declared: unlimited).
    """

    params: VehicleParams
    gains: Gains
    orientation: OrientationLaw = "corrected"
    actuators: ForceLimits | None = None

    def __post_init__(self) -> None:
        check_orientation(self.orientation)
        if self.actuators is not None and not isinstance(self.actuators, ForceLimits):
            raise ParameterError(f"actuators must be an Actuators or None, got {self.actuators!r}")

    @property
    def width(self) -> int:
        """State size per vehicle in the closed loop: 6, or :data:`INTEGRAL_WIDTH` with integral action."""
        return INTEGRAL_WIDTH if self.gains.integral else 6

    def unsaturated(
        self, states: FloatArray, p_dot: FloatArray, motion: Motion, cs: tuple[FloatArray, FloatArray] | None = None
    ) -> FloatArray:
        """Commanded body-frame thrust before saturation, shape ``(..., N, 3)`` (N, N, N m).

        Parameters
        ----------
        states : ndarray, shape (..., N, 6) or (..., N, 8)
            Measured ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s), followed with
            integral action by the integrator state ``z = int (p - p_d) dt`` (m s).
        p_dot : ndarray, shape (..., N, 2)
            Measured inertial (ground) velocity (m/s).
        motion : Motion
            Desired motion, broadcastable to the same leading shape.
        cs : tuple of ndarray, optional
            ``(cos psi, sin psi)`` of the measured headings, when the caller has them.
        """
        par = self.params
        psi, u, v, r = states[..., 2], states[..., 3], states[..., 4], states[..., 5]
        c, s = (np.cos(psi), np.sin(psi)) if cs is None else cs
        # inertial part of w_i without the drift term: -alpha e' - k1 e + p_id''
        g = self.gains
        w = -g.alpha * (p_dot - motion.v) - g.k1 * (states[..., 0:2] - motion.p) + motion.a
        if states.shape[-1] == INTEGRAL_WIDTH:  # integral action on z = int (p - p_d) dt
            w = w - g.ki * states[..., 6:8]
        # everything in the body frame: R^T w and R^T G v_d = B R^T v_d
        wx, wy = c * w[..., 0] + s * w[..., 1], -s * w[..., 0] + c * w[..., 1]
        vx = c * motion.v[..., 0] + s * motion.v[..., 1]
        vy = -s * motion.v[..., 0] + c * motion.v[..., 1]
        d11 = par.d11_lin + par.d11_quad * np.abs(u)
        d22 = par.d22_lin + par.d22_quad * np.abs(v)
        dm = (par.m22 - par.m11) * r
        bx = -d11 / par.m11 * vx + dm / par.m11 * vy  # eq. (8) body block times R^T v_d
        by = dm / par.m22 * vx - d22 / par.m22 * vy
        tau_psi = heading_torque(par, self.gains.k_psi, self.orientation, states, motion.psi, motion.r, motion.r_dot)
        return stack_last([par.m11 * (wx - bx), par.m22 * (wy - by), tau_psi])

    def forces(
        self, states: FloatArray, p_dot: FloatArray, motion: Motion, cs: tuple[FloatArray, FloatArray] | None = None
    ) -> FloatArray:
        """Applied body-frame thrust (after saturation), shape ``(..., N, 3)``; see :meth:`unsaturated`.

        Parameters
        ----------
        states : ndarray, shape (..., N, 6) or (..., N, 8)
            Measured states, as in :meth:`unsaturated`.
        p_dot : ndarray, shape (..., N, 2)
            Measured inertial (ground) velocity (m/s).
        motion : Motion
            Desired motion, broadcastable to the same leading shape.
        cs : tuple of ndarray, optional
            ``(cos psi, sin psi)`` of the measured headings, when the caller has them.
        """
        return saturate(self.unsaturated(states, p_dot, motion, cs), self.actuators, states[..., 3])[0]


@dataclass(frozen=True)
class FormationController:
    """The paper's Jacobi form of the law (eqs. 39, 41): dense ``Phi``, O(N^2) per call.

    Kept as the reference that :class:`VehicleLaw` is tested against. The desired Jacobi
    motion is ``X_d = Phi p_d`` (likewise ``Z_d = Phi p_d'``, ``Z_d' = Phi p_d''``), so a
    time-varying desired shape is allowed.

    Parameters
    ----------
    params, gains, orientation, actuators
        As in :class:`VehicleLaw`.
    transform : JacobiTransform
    reference : MotionSource
        Desired motion of the N vehicles.
    """

    params: VehicleParams
    transform: JacobiTransform
    reference: MotionSource
    gains: Gains
    orientation: OrientationLaw = "corrected"
    actuators: ForceLimits | None = None

    def __post_init__(self) -> None:
        check_orientation(self.orientation)

    def desired(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``X_d``, ``Z_d``, ``Z_d'`` at time ``t`` (s), each ``(N, 2)`` in Jacobi coordinates.

        Parameters
        ----------
        t : float
            Time (s).
        """
        m = self.reference.motion(t)
        phi = self.transform.phi
        return phi @ m.p, phi @ m.v, phi @ m.a

    def forces(self, t: float, states: FloatArray, p_dot: FloatArray) -> tuple[FloatArray, bool]:
        """Body-frame thrust ``(N, 3)`` (N, N, N m) and whether saturation was active.

        Parameters
        ----------
        t : float
            Time (s).
        states : ndarray, shape (N, 6)
            Measured ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
        p_dot : ndarray, shape (N, 2)
            Measured inertial (ground) velocities (m/s).
        """
        par, tr = self.params, self.transform
        psi, u, v, r = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
        m = self.reference.motion(t)
        x_d, z_d, z_d_dot = self.desired(t)
        x = tr.phi @ states[:, 0:2]
        z = tr.phi @ p_dot
        mu = -self.gains.alpha * (z - z_d) - self.gains.k1 * (x - x_d)  # eq. (39)
        # A Z_d = Phi G Phi^-1 Z_d, with G at the current (measured) state
        g = inertial_block(par, psi, u, v, r)
        a_zd = tr.phi @ np.einsum("nij,nj->ni", g, tr.phi_inv @ z_d)
        # Gamma U = mu - A Z_d + Z_d'  <=>  H(psi_i) tau_i = (Phi^-1 (...))_i, H^-1 = M1 R^T (eq. 41)
        w = tr.phi_inv @ (mu - a_zd + z_d_dot)
        body = np.einsum("nji,nj->ni", rotation(psi), w)
        tau_psi = heading_torque(par, self.gains.k_psi, self.orientation, states, m.psi, m.r, m.r_dot)
        tau = np.column_stack([body * np.array([par.m11, par.m22]), tau_psi])
        clipped, active = saturate(tau, self.actuators, u)
        return clipped, bool(active.any())


__all__ = [
    "INTEGRAL_WIDTH",
    "ForceLimits",
    "FormationController",
    "MotionSource",
    "RigidReference",
    "VehicleLaw",
    "VehicleMotionSource",
    "check_orientation",
    "heading_torque",
    "saturate",
]
