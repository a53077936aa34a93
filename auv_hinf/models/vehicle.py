"""3-DOF horizontal AUV model (Yang & Zhang, eqs. 1-10), one vehicle or a batch of plants.

Conventions
-----------
* State of one vehicle: ``[x, y, psi, u, v, r]`` with ``(x, y)`` the position in the
  inertial (north-east) frame in m, ``psi`` the heading in rad, ``(u, v)`` the surge and
  sway speeds in the body frame in m/s and ``r`` the yaw rate in rad/s.
* Input of one vehicle: ``[tau_x, tau_y, tau_psi]``: surge force (N), sway force (N)
  and yaw moment (N m), body frame.
* Every function broadcasts over leading axes, so a fleet of N vehicles is a stack of
  shape ``(..., N)`` (scalars) or ``(..., N, 6)`` (states).

Equations (the surge, sway and yaw equations behind eqs. 5-6; see ``docs/errata.md``)::

    m11 u' - m22 v r + d11 u = tau_x
    m22 v' + m11 u r + d22 v = tau_y
    m33 r' + (m22 - m11) u v + d33 r = tau_psi

with ``d11 = d11_lin + d11_quad |u|`` and likewise for sway (|v|) and yaw (|r|). The body
velocities are relative to the water: the ground velocity is ``R(psi) [u, v] + current``
(:func:`ground_velocity`). :class:`PlantBatch` stacks the plants of a batch of runs, and
:func:`plant_derivative` is the state derivative of every vehicle of every run under given
forces, shared by the continuous and the sampled simulation.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.numerics.arrays import stack_last

if TYPE_CHECKING:
    import control as ct

_MASS_FIELDS = ("m11", "m22", "m33")


_DAMPING_FIELDS = ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")


@dataclass(frozen=True)
class VehicleParams:
    """Rigid-body plus added-mass inertia and damping of one AUV, SI units.

    Parameters
    ----------
    m11, m22 : float
        Surge and sway inertia ``m - X_udot``, ``m - Y_vdot`` in kg (> 0).
    m33 : float
        Yaw inertia ``I_z - N_rdot`` in kg m^2 (> 0).
    d11_lin, d11_quad : float
        Surge damping ``d11 = d11_lin + d11_quad |u|``: kg/s and kg/m (>= 0).
    d22_lin, d22_quad : float
        Sway damping ``d22 = d22_lin + d22_quad |v|``: kg/s and kg/m (>= 0).
    d33_lin, d33_quad : float
        Yaw damping ``d33 = d33_lin + d33_quad |r|``: kg m^2/s and kg m^2 (>= 0).
    name : str
        Label used in reports.

    Raises
    ------
    ParameterError
        If a mass is not strictly positive, a damping coefficient is negative, or any
        value is NaN or infinite. The message names the field.
    """

    m11: float
    m22: float
    m33: float
    d11_lin: float
    d11_quad: float
    d22_lin: float
    d22_quad: float
    d33_lin: float
    d33_quad: float
    name: str = "custom"

    def __post_init__(self) -> None:
        for field in _MASS_FIELDS + _DAMPING_FIELDS:
            value = require_finite(field, getattr(self, field))
            object.__setattr__(self, field, value)
        for field in _MASS_FIELDS:
            if getattr(self, field) <= 0.0:
                raise ParameterError(f"{field} must be > 0 (an inertia), got {getattr(self, field)!r}")
        for field in _DAMPING_FIELDS:
            if getattr(self, field) < 0.0:
                raise ParameterError(f"{field} must be >= 0 (damping is dissipative), got {getattr(self, field)!r}")

    def damping(self, u: ArrayLike, v: ArrayLike, r: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Diagonal damping ``(d11, d22, d33)`` at body velocities ``(u, v, r)``.

        Parameters
        ----------
        u, v : array_like
            Surge and sway speed, m/s (body frame).
        r : array_like
            Yaw rate, rad/s.

        Returns
        -------
        d11 : ndarray
            Surge damping, kg/s, broadcast to the common shape of the inputs.
        d22 : ndarray
            Sway damping, kg/s, same shape.
        d33 : ndarray
            Yaw damping, kg m^2/s, same shape.
        """
        u_, v_, r_ = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (u, v, r)))
        return (
            self.d11_lin + self.d11_quad * np.abs(u_),
            self.d22_lin + self.d22_quad * np.abs(v_),
            self.d33_lin + self.d33_quad * np.abs(r_),
        )

    def with_damping_scale(self, factor: float) -> VehicleParams:
        """Return a copy whose six damping coefficients are multiplied by ``factor``.

        Used to model a plant/controller mismatch (e.g. ``factor=1.2`` for 20 % more drag).

        Parameters
        ----------
        factor : float
            Scale of the damping (dimensionless, finite, >= 0); the copy's name records it.
        """
        f = require_finite("damping scale factor", factor)
        if f < 0:
            raise ParameterError(f"damping scale factor must be >= 0, got {f!r}")
        scaled = {k: getattr(self, k) * f for k in _DAMPING_FIELDS}
        return replace(self, name=f"{self.name} (damping x{f:g})", **scaled)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary of the parameters."""
        return asdict(self)


def paper2011() -> VehicleParams:
    """Parameters of Yang & Zhang, Section V (adapted there from Cui et al. 2009).

    ``m11 = 200 kg, m22 = 250 kg, m33 = 80 kg m^2``, ``d11 = 70 + 100|u|``,
    ``d22 = 100 + 200|v|``, ``d33 = 50 + 100|r|``.
    """
    return VehicleParams(200.0, 250.0, 80.0, 70.0, 100.0, 100.0, 200.0, 50.0, 100.0, name="paper2011")


def _design_speed(value: float) -> float:
    """``value`` as a design surge speed (m/s): finite and > 0, else :class:`ParameterError`."""
    u0 = require_finite("design_speed", value)
    if u0 <= 0:
        raise ParameterError(f"design_speed must be > 0 m/s, got {u0!r}")
    return u0


def remus100(design_speed: float = 1.5) -> VehicleParams:
    """REMUS 100 torpedo AUV reduced to the paper's diagonal 3-DOF structure.

    Source: T. Prestero, *Verification of a six-degree of freedom simulation model for
    the REMUS autonomous underwater vehicle*, MSc thesis, MIT/WHOI, 2001
    (coefficient tables of ch. 4): ``m = 30.48 kg``, ``I_zz = 3.45 kg m^2``,
    ``X_udot = -0.93 kg``, ``Y_vdot = -35.5 kg``, ``N_rdot = -4.88 kg m^2``,
    ``X_u|u| = -1.62 kg/m``, ``Y_v|v| = -1310 kg/m``, ``N_r|r| = -94.0 kg m^2``,
    ``Y_uv = -28.6 kg/m``, ``N_ur = -2.00 kg m``.

    The reduction keeps the quadratic cross-flow drag and turns the lift terms
    ``Y_uv u v`` and ``N_ur u r`` into linear sway and yaw damping at the design surge
    speed ``u0``: ``d22_lin = -Y_uv u0``, ``d33_lin = -N_ur u0``. Prestero gives no
    linear surge damping, so ``d11_lin = 0``. Off-diagonal terms (``Y_r``, ``N_v``) are
    dropped, as the paper's model assumes.

    Provenance note: Prestero's table gives the sway cross-flow drag ``Y_v|v| = -1310 kg/m``
    but the heave drag ``Z_w|w| = -131 kg/m``. The hull is axisymmetric, so the two should be
    equal, and one of them is probably off by a factor of 10. This preset keeps the published
    1310 kg/m. The choice matters: on ``u in [0.5, 2.5] m/s``, ``|v| <= 0.3 m/s``,
    ``|r| <= 0.3 rad/s`` the envelope lambda is -6.61 1/s and the vehicle-coordinate sigma
    6.67 1/s; with 131 kg/m they are -1.25 1/s and 1.31 1/s
    (``tests/models/test_vehicle.py::test_remus100_sway_drag_sensitivity``). To study the
    alternative, use ``dataclasses.replace(remus100(), d22_quad=131.0)``.

    Parameters
    ----------
    design_speed : float
        Surge speed ``u0`` in m/s at which the lift terms are linearised (> 0).
    """
    u0 = _design_speed(design_speed)
    m, izz = 30.48, 3.45
    return VehicleParams(
        m11=m + 0.93,
        m22=m + 35.5,
        m33=izz + 4.88,
        d11_lin=0.0,
        d11_quad=1.62,
        d22_lin=28.6 * u0,
        d22_quad=1310.0,
        d33_lin=2.00 * u0,
        d33_quad=94.0,
        name=f"remus100 (u0={u0:g} m/s)",
    )


def bluerov2_heavy() -> VehicleParams:
    """BlueROV2 Heavy (Blue Robotics' open-frame ROV, 8 thrusters) in the paper's 3-DOF structure.

    Source: M. von Benzon et al., *An open-source benchmark simulator: control of a BlueROV2
    underwater robot*, J. Mar. Sci. Eng. 10 (2022) 1898, appendix parameter table, which lists
    magnitudes: ``m = 13.5 kg``, ``I_z = 0.37 kg m^2``, added masses ``X_udot = 6.36 kg``,
    ``Y_vdot = 7.12 kg``, ``N_rdot = 0.22 kg m^2``, linear damping ``X_u = 13.7 kg/s``,
    ``Y_v = N_r = 0``, quadratic damping ``X_u|u| = 141 kg/m``, ``Y_v|v| = 217 kg/m``,
    ``N_r|r| = 1.5 kg m^2``. So ``m11 = m + X_udot``, ``m22 = m + Y_vdot``, ``m33 = I_z + N_rdot``,
    ``d11 = 13.7 + 141|u|``, ``d22 = 217|v|``, ``d33 = 1.5|r|``. The model has no lift terms,
    hence no design speed. Its thrusters are :func:`auv_hinf.actuation.thrusters.bluerov2_heavy_thrusters`.
    """
    m, izz = 13.5, 0.37
    return VehicleParams(
        m11=m + 6.36,
        m22=m + 7.12,
        m33=izz + 0.22,
        d11_lin=13.7,
        d11_quad=141.0,
        d22_lin=0.0,
        d22_quad=217.0,
        d33_lin=0.0,
        d33_quad=1.5,
        name="bluerov2-heavy",
    )


#: Length (m) of the NPS AUV II, the scale of its nondimensional derivatives.
NPS_AUV2_LENGTH = 5.3
#: Water density (kg/m^3) of the NPS AUV II's model (Fossen's ``npsauv.m``).
NPS_AUV2_DENSITY = 1000.0


def nps_auv2(design_speed: float = 1.5) -> VehicleParams:
    """NPS AUV II (Naval Postgraduate School, 5.3 m torpedo AUV) reduced to the paper's diagonal 3-DOF structure.

    Source: A. J. Healey and D. Lienard, *Multivariable sliding mode control for autonomous diving
    and steering of unmanned underwater vehicles*, IEEE J. Oceanic Eng. 18(3) (1993) 327-339, as
    coded in Fossen's Marine Systems Simulator (``VESSELS/npsauv.m``): ``L = 5.3 m``,
    ``rho = 1000 kg/m^3``, ``m = 5454.54 kg``, ``I_z = 13587 kg m^2`` and the nondimensional
    derivatives ``X_udot = -7.6e-3``, ``Y_vdot = -5.5e-2``, ``N_rdot = -3.4e-3``, ``Y_v = -0.1``,
    ``N_r = -1.6e-2``, ``C_d0 = 0.00385``, scaled by ``rho L^k / 2`` (``k = 3, 3, 5, 2, 4, 2``).

    As for :func:`remus100`, the lift terms ``Y_v u v`` and ``N_r u r`` become linear damping at
    the design surge speed ``u0`` and the off-diagonal terms (``Y_r``, ``N_v``) are dropped. The
    surge drag is the model's ``rho L^2 C_d0 u^2 / 2``; the sway and yaw cross-flow drag are the
    model's 11-station sums at ``r = 0`` and ``v = 0``: ``rho/2 sum 0.3 dx`` and
    ``rho/2 sum 0.3 |x|^3 dx`` (``dx = L/10``).

    Parameters
    ----------
    design_speed : float
        Surge speed ``u0`` in m/s at which the lift terms are linearised (> 0).
    """
    u0 = _design_speed(design_speed)
    length, rho = NPS_AUV2_LENGTH, NPS_AUV2_DENSITY
    r2, r3, r4, r5 = (0.5 * rho * length**k for k in (2, 3, 4, 5))
    m, izz = 5454.54, 13587.0
    dx = length / 10.0
    stations = [-0.5 * length + k * dx for k in range(11)]
    return VehicleParams(
        m11=m + 7.6e-3 * r3,
        m22=m + 5.5e-2 * r3,
        m33=izz + 3.4e-3 * r5,
        d11_lin=0.0,
        d11_quad=0.00385 * r2,
        d22_lin=0.1 * r2 * u0,
        d22_quad=0.5 * rho * sum(0.3 * dx for _ in stations),
        d33_lin=1.6e-2 * r4 * u0,
        d33_quad=0.5 * rho * sum(0.3 * abs(x) ** 3 * dx for x in stations),
        name=f"nps-auv2 (u0={u0:g} m/s)",
    )


PRESETS: dict[str, Callable[[], VehicleParams]] = {
    "paper2011": paper2011,
    "remus100": remus100,
    "bluerov2-heavy": bluerov2_heavy,
    "nps-auv2": nps_auv2,
}


#: Presets whose lift terms are linear damping at a design surge speed (``design_speed``, m/s).
SPEED_LINEARISED: frozenset[str] = frozenset({"remus100", "nps-auv2"})


def preset(name: str, design_speed: float | None = None) -> VehicleParams:
    """Return the vehicle preset called ``name`` (one of :data:`PRESETS`).

    Parameters
    ----------
    name : str
        A key of :data:`PRESETS`; presets with arguments get their defaults.
    design_speed : float or None
        For a preset of :data:`SPEED_LINEARISED`: the surge speed (m/s) its lift terms are
        linearised at (``None``: its default, 1.5 m/s); ignored by the others.

    Raises
    ------
    ParameterError
        If ``name`` is not a preset.
    """
    try:
        make = PRESETS[name]
    except KeyError:
        raise ParameterError(f"unknown vehicle preset {name!r}; expected one of {sorted(PRESETS)}") from None
    if design_speed is not None and name in SPEED_LINEARISED:
        return cast(Callable[[float], VehicleParams], make)(design_speed)
    return make()


def rotation(psi: ArrayLike) -> FloatArray:
    """Planar rotation ``R(psi)`` from body to inertial frame, shape ``(..., 2, 2)``.

    Parameters
    ----------
    psi : array_like
        Heading, rad.
    """
    p = np.asarray(psi, dtype=float)
    c, s = np.cos(p), np.sin(p)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def coriolis_damping_matrix(params: VehicleParams, u: ArrayLike, v: ArrayLike, r: ArrayLike) -> FloatArray:
    """``M1^-1 D1(r, |u|, |v|)`` of eq. (5), body frame, shape ``(..., 2, 2)``, in 1/s.

    ``D1 = [[d11, -m22 r], [m11 r, d22]]`` holds the damping and the Coriolis coupling.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    u, v : array_like
        Surge and sway speed, m/s (body frame).
    r : array_like
        Yaw rate, rad/s.
    """
    d11, d22, _ = params.damping(u, v, r)
    r_ = np.broadcast_to(np.asarray(r, dtype=float), d11.shape)
    row0 = np.stack([d11 / params.m11, -params.m22 * r_ / params.m11], -1)
    row1 = np.stack([params.m11 * r_ / params.m22, d22 / params.m22], -1)
    return np.stack([row0, row1], -2)


def body_block(params: VehicleParams, u: ArrayLike, v: ArrayLike, r: ArrayLike) -> FloatArray:
    """Body-frame block ``S(r) - M1^-1 D1`` of eq. (8), shape ``(..., 2, 2)``, in 1/s.

    Equal to ``[[-d11/m11, (m22-m11) r/m11], [(m22-m11) r/m22, -d22/m22]]``
    (eq. 20 equals eq. 8; ``tests/models/test_vehicle.py::test_eq20_equals_eq8_symbolically``).

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    u, v : array_like
        Surge and sway speed, m/s (body frame).
    r : array_like
        Yaw rate, rad/s.
    """
    md = coriolis_damping_matrix(params, u, v, r)
    r_ = np.asarray(r, dtype=float)
    r_ = np.broadcast_to(r_, md.shape[:-2])
    skew = np.stack([np.stack([np.zeros_like(r_), -r_], -1), np.stack([r_, np.zeros_like(r_)], -1)], -2)
    return skew - md


def inertial_block(params: VehicleParams, psi: ArrayLike, u: ArrayLike, v: ArrayLike, r: ArrayLike) -> FloatArray:
    """``G(psi, r, |u|, |v|) = R(psi) [S(r) - M1^-1 D1] R(psi)^T`` of eq. (8), in 1/s.

    Maps the inertial velocity ``p'`` (m/s) to its drift acceleration, shape ``(..., 2, 2)``.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    psi : array_like
        Heading, rad.
    u, v : array_like
        Surge and sway speed, m/s (body frame).
    r : array_like
        Yaw rate, rad/s.
    """
    rot = rotation(psi)
    blk = body_block(params, u, v, r)
    return rot @ blk @ np.swapaxes(rot, -1, -2)


def input_matrix(params: VehicleParams, psi: ArrayLike) -> FloatArray:
    """``H(psi) = R(psi) M1^-1`` of eq. (9), shape ``(..., 2, 2)``, in 1/kg.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters (``m11``, ``m22`` are used).
    psi : array_like
        Heading, rad.
    """
    return rotation(psi) @ np.diag([1.0 / params.m11, 1.0 / params.m22])


def rhs(
    params: VehicleParams, state: ArrayLike, tau: ArrayLike, cs: tuple[FloatArray, FloatArray] | None = None
) -> FloatArray:
    """Time derivative of vehicle states (eqs. 1-6), vectorised over leading axes.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    state : array_like, shape (..., 6)
        ``[x, y, psi, u, v, r]`` in m, m, rad, m/s, m/s, rad/s.
    tau : array_like, shape (..., 3)
        ``[tau_x, tau_y, tau_psi]`` in N, N, N m (body frame).
    cs : tuple of ndarray, optional
        ``(cos psi, sin psi)`` when the caller has them already.

    Returns
    -------
    ndarray, shape (..., 6)
        ``[x', y', psi', u', v', r']``.
    """
    s = np.asarray(state, dtype=float)
    f = np.asarray(tau, dtype=float)
    psi, u, v, r = s[..., 2], s[..., 3], s[..., 4], s[..., 5]
    d11, d22, d33 = params.damping(u, v, r)
    c, sn = (np.cos(psi), np.sin(psi)) if cs is None else cs
    m11, m22, m33 = params.m11, params.m22, params.m33
    return stack_last(
        [
            c * u - sn * v,
            sn * u + c * v,
            r,
            (f[..., 0] + m22 * v * r - d11 * u) / m11,
            (f[..., 1] - m11 * u * r - d22 * v) / m22,
            (f[..., 2] - (m22 - m11) * u * v - d33 * r) / m33,
        ]
    )


def vehicle_nlsys(params: VehicleParams, name: str = "auv") -> ct.NonlinearIOSystem:
    """One vehicle as a python-control ``nlsys`` with ``updfcn(t, x, u, params)``.

    States ``x, y, psi, u, v, r``; inputs ``tau_x, tau_y, tau_psi``; outputs the full
    state. Use ``control.linearize(sys, xeq, ueq)`` to linearise at a trim point.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    name : str
        Name of the system.
    """

    import control as ct  # python-control costs about 1 s to import: the configuration layer does not need it

    def updfcn(t: float, x: FloatArray, u: FloatArray, p: dict[str, Any] | None) -> FloatArray:
        return rhs(params, x, u)

    return ct.nlsys(
        updfcn,
        None,
        inputs=["tau_x", "tau_y", "tau_psi"],
        states=["x", "y", "psi", "u", "v", "r"],
        outputs=["x", "y", "psi", "u", "v", "r"],
        name=name,
    )


def plant_derivative(
    plant: VehicleParams,
    current: FloatArray,
    states: FloatArray,
    forces: FloatArray,
    cs: tuple[FloatArray, FloatArray],
    p_dot: FloatArray | None = None,
) -> FloatArray:
    """``d/dt`` of states ``(..., N, 6)`` under body forces ``(..., N, 3)`` (N, N, N m).

    The position rate is the ground velocity ``R(psi) [u, v] + current``.

    Parameters
    ----------
    plant : VehicleParams
        Plant parameters, or array-valued ones (:meth:`PlantBatch.coefficients`).
    current : ndarray
        Water current (m/s, inertial frame); broadcasts to ``(..., N, 2)``.
    states : ndarray, shape (..., N, 6)
        ``[x, y, psi, u, v, r]`` in m, m, rad, m/s, m/s, rad/s.
    forces : ndarray, shape (..., N, 3)
        ``[tau_x, tau_y, tau_psi]`` in N, N, N m (body frame).
    cs : tuple of ndarray
        ``(cos psi, sin psi)`` of the states, shape ``(..., N)`` each.
    p_dot : ndarray, shape (..., N, 2), optional
        The ground velocity (m/s, inertial) when the caller has it already.
    """
    ground = ground_velocity(states, current, cs) if p_dot is None else p_dot
    d = rhs(plant, states, forces, cs)
    d[..., 0:2] = ground
    return d


def ground_velocity(
    states: FloatArray, current: FloatArray | tuple[float, float], cs: tuple[FloatArray, FloatArray] | None = None
) -> FloatArray:
    """Inertial velocity ``R(psi) [u, v] + current`` of states ``(..., N, 6)`` (m/s).

    Parameters
    ----------
    states : ndarray, shape (..., N, 6)
        ``[x, y, psi, u, v, r]`` in m, m, rad, m/s, m/s, rad/s.
    current : ndarray or tuple of float
        Water current (m/s, inertial frame); broadcasts against ``(..., N, 2)``.
    cs : tuple of ndarray, optional
        ``(cos psi, sin psi)`` of the states when the caller has them.
    """
    c, s = (np.cos(states[..., 2]), np.sin(states[..., 2])) if cs is None else cs
    u, v = states[..., 3], states[..., 4]
    out: FloatArray = stack_last([c * u - s * v, s * u + c * v]) + np.asarray(current, dtype=float)
    return out


_COEFFS = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")


@dataclass(frozen=True)
class PlantBatch:
    """Plant parameters of ``S`` scenarios: the nine :class:`VehicleParams` coefficients as arrays (S,).

    Attributes
    ----------
    m11, m22 : ndarray, shape (S,)
        Surge and sway inertia (kg).
    m33 : ndarray, shape (S,)
        Yaw inertia (kg m^2).
    d11_lin, d11_quad : ndarray, shape (S,)
        Surge damping coefficients (kg/s, kg/m).
    d22_lin, d22_quad : ndarray, shape (S,)
        Sway damping coefficients (kg/s, kg/m).
    d33_lin, d33_quad : ndarray, shape (S,)
        Yaw damping coefficients (kg m^2/s, kg m^2).
    """

    m11: FloatArray
    m22: FloatArray
    m33: FloatArray
    d11_lin: FloatArray
    d11_quad: FloatArray
    d22_lin: FloatArray
    d22_quad: FloatArray
    d33_lin: FloatArray
    d33_quad: FloatArray

    def __post_init__(self) -> None:
        arrays = [np.atleast_1d(np.asarray(getattr(self, k), dtype=float)) for k in _COEFFS]
        if any(a.ndim != 1 or a.shape != arrays[0].shape for a in arrays):
            raise ParameterError("plant coefficients must be 1-D arrays of one common length S")
        for k, a in zip(_COEFFS, arrays):
            object.__setattr__(self, k, a)
        for s in range(len(self)):
            self[s]  # VehicleParams checks signs and finiteness, naming the field

    @classmethod
    def from_params(cls, params: Sequence[VehicleParams]) -> PlantBatch:
        """Stack a list of :class:`VehicleParams`.

        Parameters
        ----------
        params : sequence of VehicleParams
            One plant per scenario (at least one); names are dropped.
        """
        if len(params) == 0:
            raise ParameterError("a plant batch needs at least one VehicleParams")
        return cls(**{k: np.array([getattr(p, k) for p in params]) for k in _COEFFS})

    def __len__(self) -> int:
        return int(self.m11.shape[0])

    def __getitem__(self, s: int) -> VehicleParams:
        return VehicleParams(**{k: float(getattr(self, k)[s]) for k in _COEFFS}, name=f"plant[{s}]")

    def coefficients(self, trailing: int, rows: NDArray[np.int_] | None = None) -> VehicleParams:
        """Duck-typed parameters with arrays of shape ``(S,) + (1,) * trailing`` for :func:`vehicle.rhs`.

        ``vehicle.rhs`` reads only the nine coefficients and ``damping``, which broadcast.

        Parameters
        ----------
        trailing : int
            Number of length-1 axes appended after the scenario axis (e.g. 1 for ``(S, N)``
            per-vehicle arrays).
        rows : ndarray of int, optional
            Only those scenarios (then ``S = rows.size``); default all.
        """
        pick = slice(None) if rows is None else rows
        shape = (-1,) + (1,) * trailing
        return cast(VehicleParams, _Coefficients({k: getattr(self, k)[pick].reshape(shape) for k in _COEFFS}))


class _Coefficients:
    """Array-valued stand-in for :class:`VehicleParams` (see :meth:`PlantBatch.coefficients`)."""

    damping = VehicleParams.damping

    def __init__(self, values: dict[str, FloatArray]) -> None:
        self.__dict__.update(values)


__all__ = [
    "NPS_AUV2_DENSITY",
    "NPS_AUV2_LENGTH",
    "PRESETS",
    "SPEED_LINEARISED",
    "PlantBatch",
    "VehicleParams",
    "bluerov2_heavy",
    "body_block",
    "coriolis_damping_matrix",
    "ground_velocity",
    "inertial_block",
    "input_matrix",
    "nps_auv2",
    "paper2011",
    "plant_derivative",
    "preset",
    "remus100",
    "rhs",
    "rotation",
    "vehicle_nlsys",
]
