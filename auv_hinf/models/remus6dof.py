"""A six-degree-of-freedom REMUS 100 from Prestero's coefficients, to test the 3-DOF results on.

The equations are Prestero's (T. Prestero, *Verification of a six-degree of freedom simulation
model for the REMUS autonomous underwater vehicle*, MSc thesis, MIT/WHOI, 2001, ch. 3-4), in
the body frame with its origin at the centre of buoyancy and the centre of gravity ``z_g`` below
it. Written out with ``x_g = y_g = 0``, the rigid body's accelerations and the added masses form the
constant mass matrix :func:`mass_matrix`; every other term (the rigid body's centripetal terms, the
hydrostatics, the quadratic cross-flow drag, the combined added-mass / lift terms such as
``Y_uv u v`` and ``N_ur u r``, the fins and the propeller) is in :func:`forces`. The coefficients
are :class:`Remus6Dof`, from Prestero's tables (docs/vehicles.md).

The states are ``[x, y, z, phi, theta, psi, u, v, w, p, q, r]``: north, east, down (m), the
zyx Euler angles (rad), and the velocity through the water in the body frame (m/s, rad/s).
A constant current (m/s, inertial, horizontal) moves the vehicle with the water: the dynamics are
in the velocity through the water and the kinematics add the current, as the 3-DOF model of
:mod:`auv_hinf.models.vehicle` is used (exact for an irrotational constant current when the
rigid-body terms are written in the relative velocity).

What the 3-DOF model drops, and this one keeps: the heave, roll and pitch, the off-diagonal
added masses ``Y_rdot`` and ``N_vdot``, the coupling of sway and yaw through ``N_uv u v`` (the
Munk moment with the fins' lift) and ``Y_ur u r``, the propeller's roll torque and the
hydrostatic restoring moments of the offset centre of gravity.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite, require_positive

#: Number of states of the model.
STATES = 12
#: Index of each state in the state vector.
X, Y, Z, PHI, THETA, PSI, U, V, W, P, Q, R = range(STATES)


@dataclass(frozen=True)
class Remus6Dof:
    """Prestero's REMUS 100 coefficients (SI units; kg, m, rad).

    The names follow Prestero: ``y_uv`` is ``Y_uv`` (the sway force per ``u v``), ``y_vdot`` the
    added mass ``Y_vdot``. The values are those of Prestero's tables; ``z_ww`` keeps his
    published -131 kg/m, a tenth of ``y_vv`` (see :func:`~auv_hinf.models.vehicle.remus100`).
    ``x_prop`` and ``k_prop`` are his steady propeller thrust and torque at 1.5 m/s: here the
    torque follows the commanded thrust in proportion (both grow as the square of the rate).

    Attributes
    ----------
    mass, weight, buoyancy, z_g, i_xx, i_yy, i_zz : float
        Mass (kg), weight and buoyancy (N), centre of gravity below the centre of buoyancy (m),
        moments of inertia (kg m^2).
    x_uu, x_udot, x_wq, x_qq, x_vr, x_rr, x_prop : float
        Surge: drag (kg/m), added mass (kg), cross terms (kg/rad, kg m/rad^2), propeller thrust (N).
    y_vv, y_rr, y_uv, y_vdot, y_rdot, y_ur, y_wp, y_pq, y_uudr : float
        Sway: cross-flow drag (kg/m, kg m/rad^2), lift (kg/m), added masses (kg, kg m/rad), cross
        terms (kg/rad, kg m/rad^2), rudder (kg/(m rad)).
    z_ww, z_qq, z_uw, z_wdot, z_qdot, z_uq, z_vp, z_rp, z_uuds : float
        Heave: the same terms, with the stern planes (kg/(m rad)).
    k_pp, k_pdot, k_prop : float
        Roll: drag (kg m^2/rad^2), added inertia (kg m^2/rad), propeller torque (N m).
    m_ww, m_qq, m_uw, m_wdot, m_qdot, m_uq, m_vp, m_rp, m_uuds : float
        Pitch: cross-flow drag (kg, kg m^2/rad^2), Munk and lift moment (kg), added masses (kg m,
        kg m^2/rad), cross terms, stern planes (kg/rad).
    n_vv, n_rr, n_uv, n_vdot, n_rdot, n_ur, n_wp, n_pq, n_uudr : float
        Yaw: the same terms as pitch, with the rudder (kg/rad).
    """

    mass: float = 30.48
    weight: float = 299.0
    buoyancy: float = 306.0
    z_g: float = 0.0196
    i_xx: float = 0.177
    i_yy: float = 3.45
    i_zz: float = 3.45
    x_uu: float = -1.62
    x_udot: float = -0.93
    x_wq: float = -35.5
    x_qq: float = -1.93
    x_vr: float = 35.5
    x_rr: float = -1.93
    x_prop: float = 3.86
    y_vv: float = -1310.0
    y_rr: float = 0.632
    y_uv: float = -28.6
    y_vdot: float = -35.5
    y_rdot: float = 1.93
    y_ur: float = 5.22
    y_wp: float = 35.5
    y_pq: float = 1.93
    y_uudr: float = 9.64
    z_ww: float = -131.0
    z_qq: float = -0.632
    z_uw: float = -28.6
    z_wdot: float = -35.5
    z_qdot: float = -1.93
    z_uq: float = -5.22
    z_vp: float = -35.5
    z_rp: float = 1.93
    z_uuds: float = -9.64
    k_pp: float = -1.30e-3
    k_pdot: float = -1.41e-2
    k_prop: float = -0.543
    m_ww: float = 3.18
    m_qq: float = -188.0
    m_uw: float = 24.0
    m_wdot: float = -1.93
    m_qdot: float = -4.88
    m_uq: float = -2.0
    m_vp: float = -1.93
    m_rp: float = 4.86
    m_uuds: float = -6.15
    n_vv: float = -3.18
    n_rr: float = -94.0
    n_uv: float = -24.0
    n_vdot: float = 1.93
    n_rdot: float = -4.88
    n_ur: float = -2.0
    n_wp: float = -1.93
    n_pq: float = -4.86
    n_uudr: float = -6.15

    def __post_init__(self) -> None:
        for f in fields(self):
            require_finite(f.name, getattr(self, f.name))
        for name in ("mass", "weight", "buoyancy", "i_xx", "i_yy", "i_zz", "x_prop"):
            require_positive(name, getattr(self, name))
        mm = mass_matrix(self)
        if not np.linalg.eigvalsh(0.5 * (mm + mm.T)).min() > 0.0:
            raise ParameterError("the mass matrix (rigid body plus added mass) must be positive definite")


def mass_matrix(c: Remus6Dof) -> FloatArray:
    """The 6 x 6 mass matrix of ``[u, v, w, p, q, r]'``: rigid body (centre of gravity ``z_g`` below) plus added mass.

    Parameters
    ----------
    c : Remus6Dof
        The coefficients.
    """
    m, zg = c.mass, c.z_g
    return np.array(
        [
            [m - c.x_udot, 0.0, 0.0, 0.0, m * zg, 0.0],
            [0.0, m - c.y_vdot, 0.0, -m * zg, 0.0, -c.y_rdot],
            [0.0, 0.0, m - c.z_wdot, 0.0, -c.z_qdot, 0.0],
            [0.0, -m * zg, 0.0, c.i_xx - c.k_pdot, 0.0, 0.0],
            [m * zg, 0.0, -c.m_wdot, 0.0, c.i_yy - c.m_qdot, 0.0],
            [0.0, -c.n_vdot, 0.0, 0.0, 0.0, c.i_zz - c.n_rdot],
        ]
    )


def forces(c: Remus6Dof, state: FloatArray, thrust: FloatArray, rudder: FloatArray, stern: FloatArray) -> FloatArray:
    """Every force and moment but the accelerations' (N, N m), shape ``(..., 6)``.

    Parameters
    ----------
    c : Remus6Dof
        The coefficients.
    state : ndarray, shape (..., 12)
        The states (see the module docstring).
    thrust : ndarray, shape (...)
        Propeller thrust (N).
    rudder, stern : ndarray, shape (...)
        Rudder and stern-plane deflections (rad).
    """
    phi, theta = state[..., PHI], state[..., THETA]
    u, v, w, p, q, r = (state[..., k] for k in (U, V, W, P, Q, R))
    m, zg, excess = c.mass, c.z_g, c.weight - c.buoyancy
    cth, sth, cph, sph = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    uu = u * u
    fx = (
        -excess * sth
        + c.x_uu * u * np.abs(u) + c.x_wq * w * q + c.x_qq * q * q + c.x_vr * v * r + c.x_rr * r * r
        + thrust
        - m * (-v * r + w * q + zg * p * r)
    )  # fmt: skip
    fy = (
        excess * cth * sph
        + c.y_vv * v * np.abs(v) + c.y_rr * r * np.abs(r) + c.y_ur * u * r + c.y_wp * w * p + c.y_pq * p * q
        + c.y_uv * u * v + c.y_uudr * uu * rudder
        - m * (-w * p + u * r + zg * q * r)
    )  # fmt: skip
    fz = (
        excess * cth * cph
        + c.z_ww * w * np.abs(w) + c.z_qq * q * np.abs(q) + c.z_uq * u * q + c.z_vp * v * p + c.z_rp * r * p
        + c.z_uw * u * w + c.z_uuds * uu * stern
        - m * (-u * q + v * p - zg * (p * p + q * q))
    )  # fmt: skip
    fk = (
        -zg * c.weight * cth * sph
        + c.k_pp * p * np.abs(p) + c.k_prop * thrust / c.x_prop
        - (c.i_zz - c.i_yy) * q * r
        + m * zg * (-w * p + u * r)
    )  # fmt: skip
    fm = (
        -zg * c.weight * sth
        + c.m_ww * w * np.abs(w) + c.m_qq * q * np.abs(q) + c.m_uq * u * q + c.m_vp * v * p + c.m_rp * r * p
        + c.m_uw * u * w + c.m_uuds * uu * stern
        - (c.i_xx - c.i_zz) * r * p
        - m * zg * (-v * r + w * q)
    )  # fmt: skip
    fn = (
        c.n_vv * v * np.abs(v) + c.n_rr * r * np.abs(r) + c.n_ur * u * r + c.n_wp * w * p + c.n_pq * p * q
        + c.n_uv * u * v + c.n_uudr * uu * rudder
        - (c.i_yy - c.i_xx) * p * q
    )  # fmt: skip
    return np.stack([fx, fy, fz, fk, fm, fn], axis=-1)


def kinematics(state: FloatArray, current: FloatArray) -> FloatArray:
    """``[x, y, z, phi, theta, psi]'`` (m/s, rad/s): the body velocities turned to the earth, plus the current.

    Parameters
    ----------
    state : ndarray, shape (..., 12)
        The states.
    current : ndarray, shape (2,)
        The horizontal current (m/s, north and east).
    """
    phi, theta, psi = state[..., PHI], state[..., THETA], state[..., PSI]
    u, v, w, p, q, r = (state[..., k] for k in (U, V, W, P, Q, R))
    cph, sph, cth, sth, cps, sps = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    xd = cps * cth * u + (cps * sth * sph - sps * cph) * v + (cps * sth * cph + sps * sph) * w + current[0]
    yd = sps * cth * u + (sps * sth * sph + cps * cph) * v + (sps * sth * cph - cps * sph) * w + current[1]
    zd = -sth * u + cth * sph * v + cth * cph * w
    phid = p + (q * sph + r * cph) * np.tan(theta)
    thetad = q * cph - r * sph
    psid = (q * sph + r * cph) / cth
    return np.stack([xd, yd, zd, phid, thetad, psid], axis=-1)


def derivative(
    c: Remus6Dof,
    state: FloatArray,
    thrust: FloatArray,
    rudder: FloatArray,
    stern: FloatArray,
    current: FloatArray,
    inverse_mass: FloatArray | None = None,
) -> FloatArray:
    """The time derivative of ``state`` (..., 12).

    Parameters
    ----------
    c : Remus6Dof
        The coefficients.
    state : ndarray, shape (..., 12)
        The states.
    thrust, rudder, stern : ndarray, shape (...)
        Propeller thrust (N), rudder and stern-plane deflections (rad).
    current : ndarray, shape (2,)
        Horizontal current (m/s).
    inverse_mass : ndarray, shape (6, 6), optional
        ``inv(mass_matrix(c))`` when the caller has it.
    """
    minv = np.linalg.inv(mass_matrix(c)) if inverse_mass is None else inverse_mass
    accel = forces(c, state, thrust, rudder, stern) @ minv.T
    return np.concatenate([kinematics(state, current), accel], axis=-1)


__all__ = ["STATES", "Remus6Dof", "derivative", "forces", "kinematics", "mass_matrix"]
