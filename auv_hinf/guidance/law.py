"""Line-of-sight guidance and autopilots for a vehicle with a propeller and a rudder only.

A torpedo AUV (REMUS 100, LAUV, Iver3) cannot push sideways: it follows its slot path by
pointing at it. Each vehicle's slot moves along ``p_d(t)`` (the formation's desired motion,
:class:`~auv_hinf.mission.fleet.FleetReference`), with course ``gamma = atan2(p_d')``, speed
``U = |p_d'|`` and course rate ``omega``. In the slot's path-tangential frame the vehicle's
position error has an along-track part ``x_e`` and a cross-track part ``y_e`` (m).

Guidance (integral line of sight, ILOS; Borhaug, Pavlov & Pettersen 2008)::

    psi_d  = gamma - atan((y_e + sigma y_i) / Delta)
    y_i'   = Delta y_e / ((y_e + sigma y_i)^2 + Delta^2)          (ILOS; LOS: y_i = 0)

with the lookahead distance ``Delta`` (m) and the integral gain ``sigma`` (m/s). The integral
term is what turns the vehicle's heading into the current (a crab angle), so that a constant
cross current leaves no cross-track offset; plain LOS leaves one of about ``Delta c / U``.

Along-track coordination: the vehicle holds its slot by steering its along-track *ground*
speed (the DVL's bottom-track velocity) to ``U - k_x x_e / sqrt(1 + (x_e / L_x)^2)``: it speeds up
when behind its slot and slows down when ahead, at most by ``k_x L_x``.

Autopilots, on the controller's own model (the nominal vehicle):

* heading: ``delta = [m33 (-k_p e_psi - k_d (r - r_d)) + d33(r) r + (m22 - m11) u v] / (N_uu_delta u^2)``,
  clipped to the rudder's ``+-rudder_max``, where ``e_psi = psi - psi_d`` and ``r_d = psi_d'`` is
  the exact derivative of the guidance law along the measured ground velocity;
* surge: ``T = m11 (U' - k_u (s - s_d)) + d11(u) u - m22 v r`` with ``s`` the along-track ground
  speed and ``s_d`` its command, clipped to ``+-tau_x``.

The sway velocity is left to its own damped dynamics: the rudder's sway force
``Y_uu_delta u^2 delta`` is what the vehicle gets, not a command.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.mission.fleet import wrap_angle
from auv_hinf.models.vehicle import VehicleParams

#: Line-of-sight guidance kinds: plain LOS, or integral LOS (removes a constant current's offset).
GuidanceKind = Literal["los", "ilos"]
GUIDANCE_KINDS: tuple[str, ...] = ("los", "ilos")

#: Default lookahead distance (m). Longer than the 1.5-2.5 hull lengths of ship practice
#: (Fossen 2021, sec. 12.4) because a small fin gives a torpedo AUV little turning authority:
#: at 8 m a 1 m cross-track step asks for a 7 deg heading change.
DEFAULT_LOOKAHEAD = 8.0
#: Default ILOS integral gain (m/s): well below the survey speed, as the ILOS stability
#: conditions ask (Caharija et al. 2016: the gain must stay below the speed less the current).
DEFAULT_INTEGRAL_GAIN = 0.3
#: Default heading-loop natural frequency (rad/s), critically damped.
DEFAULT_HEADING_BANDWIDTH = 1.0
#: Default surge-speed loop gain (1/s).
DEFAULT_SPEED_GAIN = 1.0
#: Default along-track position gain (1/s).
DEFAULT_ALONG_TRACK_GAIN = 0.2
#: Default length (m) at which the along-track correction saturates (to ``k_x L_x`` m/s).
DEFAULT_ALONG_TRACK_LENGTH = 5.0
#: Surge speed (m/s) below which the rudder command is computed as at this speed: a fin has no
#: authority at rest, and the division by ``u^2`` must not blow up.
MIN_RUDDER_SPEED = 0.2


@dataclass(frozen=True)
class GuidanceConfig:
    """The ``[guidance]`` table: line-of-sight guidance and the autopilots' gains.

    Parameters
    ----------
    kind : {"los", "ilos"}
        Plain or integral line of sight.
    lookahead : float
        Lookahead distance ``Delta`` (m, > 0).
    integral_gain : float
        ILOS gain ``sigma`` (m/s, > 0; unused by plain LOS).
    heading_bandwidth : float
        Natural frequency of the critically damped heading loop (rad/s, > 0).
    speed_gain : float
        Gain ``k_u`` of the along-track ground-speed loop (1/s, > 0).
    along_track_gain : float
        Gain ``k_x`` of the along-track position correction (1/s, >= 0).
    along_track_length : float
        Length ``L_x`` (m, > 0) over which the along-track correction saturates.

    Raises
    ------
    ParameterError
        If a value is not finite or outside its range, or the kind is unknown.
    """

    kind: GuidanceKind = "ilos"
    lookahead: float = DEFAULT_LOOKAHEAD
    integral_gain: float = DEFAULT_INTEGRAL_GAIN
    heading_bandwidth: float = DEFAULT_HEADING_BANDWIDTH
    speed_gain: float = DEFAULT_SPEED_GAIN
    along_track_gain: float = DEFAULT_ALONG_TRACK_GAIN
    along_track_length: float = DEFAULT_ALONG_TRACK_LENGTH

    def __post_init__(self) -> None:
        if self.kind not in GUIDANCE_KINDS:
            raise ParameterError(f"guidance.kind must be one of {GUIDANCE_KINDS}, got {self.kind!r}")
        for name in ("lookahead", "integral_gain", "heading_bandwidth", "speed_gain", "along_track_length"):
            value = require_finite(f"guidance.{name}", getattr(self, name))
            if value <= 0.0:
                raise ParameterError(f"guidance.{name} must be > 0, got {value!r}")
            object.__setattr__(self, name, value)
        gain = require_finite("guidance.along_track_gain", self.along_track_gain)
        if gain < 0.0:
            raise ParameterError(f"guidance.along_track_gain must be >= 0 1/s, got {gain!r}")
        object.__setattr__(self, "along_track_gain", gain)

    @property
    def sigma(self) -> float:
        """The integral gain that acts (m/s): ``integral_gain`` for ILOS, 0 for LOS."""
        return self.integral_gain if self.kind == "ilos" else 0.0

    def to_dict(self) -> dict[str, Any]:
        """The table as plain data (the ``[guidance]`` keys)."""
        return asdict(self)


@dataclass(frozen=True)
class SlotMotion:
    """Each vehicle's slot at one time (inertial frame).

    Attributes
    ----------
    p, v, a : ndarray, shape (..., N, 2)
        Position (m), velocity (m/s) and acceleration (m/s^2) of every slot.
    """

    p: FloatArray
    v: FloatArray
    a: FloatArray

    @property
    def speed(self) -> FloatArray:
        """``U = |p_d'|`` (m/s)."""
        return np.asarray(np.hypot(self.v[..., 0], self.v[..., 1]))

    @property
    def course(self) -> FloatArray:
        """``gamma = atan2(p_d')`` (rad)."""
        return np.asarray(np.arctan2(self.v[..., 1], self.v[..., 0]))

    def along_across(self, x: FloatArray | float, y: FloatArray | float) -> tuple[FloatArray, FloatArray]:
        """Components of the inertial vectors ``(x, y)`` along and across each slot's track.

        Along the unit tangent ``t = p_d'/|p_d'|`` and the normal ``n`` to its left (the speed floored
        at 1e-9 m/s).

        Parameters
        ----------
        x, y : ndarray or float
            Inertial components (any unit), broadcastable to the slots' shape ``(..., N)``.
        """
        speed = np.maximum(self.speed, 1e-9)
        tx, ty = self.v[..., 0] / speed, self.v[..., 1] / speed
        return np.asarray(tx * x + ty * y), np.asarray(-ty * x + tx * y)

    @property
    def course_rate(self) -> FloatArray:
        """``omega = (p_d' x p_d'') / |p_d'|^2`` (rad/s), the course's rate (the speed floored at 1e-9 m/s)."""
        return np.asarray(
            (self.v[..., 0] * self.a[..., 1] - self.v[..., 1] * self.a[..., 0]) / np.maximum(self.speed, 1e-9) ** 2
        )


@dataclass(frozen=True)
class Commands:
    """What the cascade asks for and what the vehicle gets, shape ``(..., N)`` each.

    Attributes
    ----------
    thrust_cmd, rudder_cmd : ndarray
        Propeller thrust (N) and rudder deflection (rad) before the limits.
    thrust, rudder : ndarray
        After the limits (what acts).
    along_track, cross_track : ndarray
        ``x_e``, ``y_e`` (m).
    heading_error : ndarray
        ``psi - psi_d`` (rad, wrapped).
    integral_rate : ndarray
        ``y_i'`` (s/s: ``y_i`` is in s).
    """

    thrust_cmd: FloatArray
    rudder_cmd: FloatArray
    thrust: FloatArray
    rudder: FloatArray
    along_track: FloatArray
    cross_track: FloatArray
    heading_error: FloatArray
    integral_rate: FloatArray

    def body_forces(self, act: RudderActuation, u: FloatArray) -> FloatArray:
        """``[tau_x, tau_y, tau_psi]`` (N, N, N m) that the limited thrust and rudder make at surge speed ``u``.

        Parameters
        ----------
        act : RudderActuation
            The true rudder derivatives.
        u : ndarray, shape (..., N)
            Surge speeds (m/s).
        """
        q = u * u * self.rudder
        return np.stack([self.thrust, act.rudder_sway * q, act.rudder_yaw * q], axis=-1)


def commands(
    gcfg: GuidanceConfig,
    model: VehicleParams,
    act: RudderActuation,
    states: FloatArray,
    integral: FloatArray,
    slot: SlotMotion,
    ground: FloatArray,
) -> Commands:
    """The cascade's thrust and rudder for states ``(..., N, 6)`` following ``slot``.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance and autopilot gains.
    model : VehicleParams
        The controller's model of the vehicle (the nominal parameters).
    act : RudderActuation
        The propeller and rudder (the controller's figures).
    states : ndarray, shape (..., N, 6)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    integral : ndarray, shape (..., N)
        ILOS states ``y_i`` (s).
    slot : SlotMotion
        The slots' motion at this time.
    ground : ndarray, shape (..., N, 2)
        Measured ground velocity (m/s, inertial; a DVL's bottom track).
    """
    psi, u, v, r = states[..., 2], states[..., 3], states[..., 4], states[..., 5]
    omega = slot.course_rate
    speed_rate = (slot.v[..., 0] * slot.a[..., 0] + slot.v[..., 1] * slot.a[..., 1]) / np.maximum(slot.speed, 1e-9)
    xe, ye = slot.along_across(states[..., 0] - slot.p[..., 0], states[..., 1] - slot.p[..., 1])
    _, rel_across = slot.along_across(ground[..., 0] - slot.v[..., 0], ground[..., 1] - slot.v[..., 1])
    ye_dot = rel_across - omega * xe
    s_along, _ = slot.along_across(ground[..., 0], ground[..., 1])
    delta_ = gcfg.lookahead
    sigma = gcfg.sigma
    s = ye + sigma * integral
    den = s * s + delta_ * delta_
    yi_dot = delta_ * ye / den if sigma > 0.0 else np.zeros_like(ye)
    psi_d = np.arctan2(slot.v[..., 1], slot.v[..., 0]) - np.arctan(s / delta_)
    r_d = omega - delta_ / den * (ye_dot + sigma * yi_dot)
    e_psi = wrap_angle(psi - psi_d)
    kp, kd = gcfg.heading_bandwidth**2, 2.0 * gcfg.heading_bandwidth
    d11, _, d33 = model.damping(u, v, r)
    moment = model.m33 * (-kp * e_psi - kd * (r - r_d)) + d33 * r + (model.m22 - model.m11) * u * v
    u_eff = np.maximum(np.abs(u), MIN_RUDDER_SPEED)
    rudder_cmd = moment / (act.rudder_yaw * u_eff * u_eff)
    lx = gcfg.along_track_length
    s_d = slot.speed - gcfg.along_track_gain * xe / np.sqrt(1.0 + (xe / lx) ** 2)
    thrust_cmd = model.m11 * (speed_rate - gcfg.speed_gain * (s_along - s_d)) + d11 * u - model.m22 * v * r
    return Commands(
        thrust_cmd=thrust_cmd,
        rudder_cmd=rudder_cmd,
        thrust=np.clip(thrust_cmd, -act.tau_x, act.tau_x),
        rudder=np.clip(rudder_cmd, -act.rudder_max, act.rudder_max),
        along_track=xe,
        cross_track=ye,
        heading_error=e_psi,
        integral_rate=yi_dot,
    )


#: Largest angle (rad) between a vehicle's start heading and its slot's course that the ILOS
#: state is started to hold (:func:`integral_start`): a crab into a current is far smaller (0.13
#: rad for 0.2 m/s across 1.5 m/s); a vehicle started further off its course turns onto it.
MAX_START_CRAB = math.pi / 4


def integral_start(gcfg: GuidanceConfig, states: FloatArray, slot: SlotMotion) -> FloatArray:
    """ILOS states ``y_i`` (s) at ``t = 0`` that make the desired heading the start heading.

    On its slot (``y_e = 0``), ILOS asks for the heading ``gamma - atan(sigma y_i / Delta)``; a
    vehicle that starts crabbing into a current by ``gamma - psi`` keeps its crab when
    ``y_i = Delta tan(gamma - psi) / sigma``, instead of turning onto the course and drifting
    off until the integrator builds up (a bumpless start). Where the start heading is more than
    :data:`MAX_START_CRAB` off the course, and for LOS, ``y_i`` starts at 0.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance gains.
    states : ndarray, shape (..., N, 6)
        Start states ``[x, y, psi, u, v, r]``.
    slot : SlotMotion
        The slots at the start.
    """
    psi = states[..., 2]
    if gcfg.sigma == 0.0:
        return np.zeros_like(psi)
    crab = wrap_angle(np.arctan2(slot.v[..., 1], slot.v[..., 0]) - psi)
    held = gcfg.lookahead * np.tan(crab) / gcfg.sigma
    return np.where(np.abs(crab) < MAX_START_CRAB, held, 0.0)


__all__ = [
    "DEFAULT_ALONG_TRACK_GAIN",
    "DEFAULT_ALONG_TRACK_LENGTH",
    "DEFAULT_HEADING_BANDWIDTH",
    "DEFAULT_INTEGRAL_GAIN",
    "DEFAULT_LOOKAHEAD",
    "DEFAULT_SPEED_GAIN",
    "GUIDANCE_KINDS",
    "MAX_START_CRAB",
    "MIN_RUDDER_SPEED",
    "Commands",
    "GuidanceConfig",
    "GuidanceKind",
    "SlotMotion",
    "commands",
    "integral_start",
]
