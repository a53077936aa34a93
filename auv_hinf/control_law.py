"""Formation controller: orientation (eqs. 26-28), velocity + position (eq. 39), allocation (eq. 41).

All functions are vectorised over the N vehicles; no Python loop runs per vehicle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import control as ct
import numpy as np
from numpy.typing import NDArray

from ._typing import OrientationLaw
from .exceptions import DesignError, require_finite
from .formation import JacobiTransform
from ._typing import FloatArray
from .vehicle import VehicleParams, inertial_block, rotation

class Trajectory(Protocol):
    """Desired formation-centre trajectory ``q_cd(t)`` (inertial frame, m)."""

    def __call__(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Return position, velocity, acceleration and jerk, each shape (2,)."""
        ...


@dataclass(frozen=True)
class SineTrajectory:
    """``q_cd(t) = [speed t, amplitude sin(omega t)]`` (Section V: speed 1, amplitude 30, omega 0.1)."""

    speed: float = 1.0
    amplitude: float = 30.0
    omega: float = 0.1

    def __call__(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        a, w, s = self.amplitude, self.omega, self.speed
        sn, cs = np.sin(w * t), np.cos(w * t)
        return (
            np.array([s * t, a * sn]),
            np.array([s, a * w * cs]),
            np.array([0.0, -a * w * w * sn]),
            np.array([0.0, -a * w**3 * cs]),
        )


def wrap_angle(x: FloatArray | float) -> FloatArray:
    """Wrap angles to ``(-pi, pi]`` (rad)."""
    return np.pi - np.mod(np.pi - np.asarray(x, dtype=float), 2.0 * np.pi)


def heading_gains(params: VehicleParams, poles: tuple[float, float] = (-1.0, -1.5)) -> tuple[float, float]:
    """``(k1_psi, k2_psi)`` by pole placement (``control.place``) on eq. (27) at ``r = 0``.

    The heading-error model is ``e'' = -(d33_lin/m33) e' + V``; the poles are in 1/s.
    """
    if any((not np.isfinite(p)) or p >= 0 for p in poles):
        raise DesignError(f"heading poles must be finite and negative, got {poles!r}")
    a = np.array([[0.0, 1.0], [0.0, -params.d33_lin / params.m33]])
    b = np.array([[0.0], [1.0]])
    k = np.asarray(ct.place(a, b, list(poles))).ravel()
    return float(k[0]), float(k[1])


def heading_reference(qd: FloatArray, qdd: FloatArray, qddd: FloatArray) -> tuple[float, float, float]:
    """Direction of the desired velocity and its first two time derivatives (PAPER-NOTES 17).

    Returns ``psi_d`` (rad), ``psi_d'`` (rad/s), ``psi_d''`` (rad/s^2).
    """
    x1, y1 = qd
    x2, y2 = qdd
    x3, y3 = qddd
    den = x1 * x1 + y1 * y1
    if den <= 0:
        raise DesignError("desired velocity is zero: heading reference undefined")
    num = x1 * y2 - y1 * x2
    num_d = x1 * y3 - y1 * x3
    den_d = 2.0 * (x1 * x2 + y1 * y2)
    return float(np.arctan2(y1, x1)), num / den, (num_d * den - num * den_d) / (den * den)


@dataclass(frozen=True)
class FormationController:
    """Yang & Zhang controller with the corrected eq. (28).

    Parameters
    ----------
    params : VehicleParams
        The controller's model of the vehicles (may differ from the plant).
    transform : JacobiTransform
    shape : ndarray, shape (N-1, 2)
        Desired Jacobi shape vectors ``rho_d`` (m).
    trajectory : Trajectory
        Desired centre trajectory.
    alpha : float
        Velocity gain (1/s), from Theorem 1.
    k1 : float
        Position gain ``K1 = k1 I`` (1/s^2).
    k_psi : tuple of float
        Heading gains ``(k1_psi, k2_psi)`` (1/s^2, 1/s).
    orientation : {"corrected", "printed"}
        ``"corrected"``: ``V = psi_d'' + (d33/m33) psi_d' - k1 e - k2 e'`` (PAPER-NOTES 16);
        ``"printed"``: eq. (28) as printed, ``V = psi_d' + (d33/m33) psi_d - k1 e - k2 e'``.
    thrust_limit : tuple of float, optional
        Saturation ``(|tau_x|, |tau_y|, |tau_psi|)`` in N, N, N m.
    """

    params: VehicleParams
    transform: JacobiTransform
    shape: FloatArray
    trajectory: Trajectory
    alpha: float
    k1: float
    k_psi: tuple[float, float]
    orientation: OrientationLaw = "corrected"
    thrust_limit: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        require_finite("alpha", self.alpha)
        if require_finite("k1", self.k1) <= 0:
            raise DesignError(f"k1 must be > 0 (K1 positive definite), got {self.k1!r}")
        if self.orientation not in ("corrected", "printed"):
            raise DesignError(f"orientation must be 'corrected' or 'printed', got {self.orientation!r}")
        object.__setattr__(self, "shape", np.asarray(self.shape, dtype=float).reshape(self.transform.n - 1, 2))

    def desired(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray, tuple[float, float, float]]:
        """``X_d``, ``Z_d``, ``Z_d'`` (each (N, 2), Jacobi coords) and the heading reference."""
        q, qd, qdd, qddd = self.trajectory(t)
        zeros = np.zeros_like(self.shape)
        return (
            np.vstack([self.shape, q]),
            np.vstack([zeros, qd]),
            np.vstack([zeros, qdd]),
            heading_reference(qd, qdd, qddd),
        )

    def forces(self, t: float, states: FloatArray, p_dot: FloatArray) -> tuple[FloatArray, bool]:
        """Body-frame thrust ``(N, 3)`` and whether saturation was active.

        ``states`` is ``(N, 6)``; ``p_dot`` the measured inertial velocities ``(N, 2)`` (m/s).
        """
        par, tr = self.params, self.transform
        psi, u, v, r = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
        x_d, z_d, z_d_dot, (psi_d, psi_d1, psi_d2) = self.desired(t)
        x = tr.phi @ states[:, 0:2]
        z = tr.phi @ p_dot
        mu = -self.alpha * (z - z_d) - self.k1 * (x - x_d)  # eq. (39)
        # A Z_d = Phi G Phi^-1 Z_d, with G at the current (measured) state
        g = inertial_block(par, psi, u, v, r)
        a_zd = tr.phi @ np.einsum("nij,nj->ni", g, tr.phi_inv @ z_d)
        rhs = mu - a_zd + z_d_dot
        # Gamma U = rhs  <=>  H(psi_i) tau_i = (Phi^-1 rhs)_i, H^-1 = M1 R^T (eq. 41)
        w = tr.phi_inv @ rhs
        body = np.einsum("nji,nj->ni", rotation(psi), w)
        tau_xy = body * np.array([par.m11, par.m22])
        _, _, d33 = par.damping(u, v, r)
        e = wrap_angle(psi - psi_d)
        e_dot = r - psi_d1
        k1p, k2p = self.k_psi
        if self.orientation == "corrected":
            big_v = psi_d2 + d33 / par.m33 * psi_d1 - k1p * e - k2p * e_dot
        else:
            big_v = psi_d1 + d33 / par.m33 * psi_d - k1p * e - k2p * e_dot
        tau_psi = par.m33 * big_v - (par.m11 - par.m22) * u * v  # eq. (26)
        tau = np.column_stack([tau_xy, tau_psi])
        if self.thrust_limit is None:
            return tau, False
        lim = np.asarray(self.thrust_limit, dtype=float)
        clipped = np.clip(tau, -lim, lim)
        return clipped, bool(np.any(clipped != tau))
