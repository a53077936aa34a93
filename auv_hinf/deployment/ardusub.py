"""ArduSub's path from MANUAL_CONTROL to the BlueROV2 Heavy's horizontal thrust, both ways.

What the vehicle does (:meth:`ArduSubMapping.manual_control_to_forces`; the loopback fleet runs it)::

    MANUAL_CONTROL x, y, r in [-1000, 1000], z in [0, 1000] (500 neutral)
      -> RC override pulse   ch = trunc(1500 + 0.4 gain x), clamped to 1100-1900  (joystick.cpp)
      -> normalised input    q = (ch - 1500) / 400                               (RC_Channel norm_input)
      -> MANUAL mode         yaw input times ACRO_YAW_P / 3.375                    (mode_manual.cpp)
      -> Vectored_6DOF mix   y_i = yaw_i q_r + fwd_i q_x + lat_i q_y, over max(1, max |y_i|)
      -> motor pulse         pwm_i = trunc(1500 + 400 y_i)                         (AP_Motors6DOF)
      -> T200 thrust         f_i = T200(pwm_i, voltage)                            (thrust_curve)
      -> body force          tau = T f                                             (the allocation)

What the controller sends (:meth:`ArduSubMapping.forces_to_manual_control`): the four mixed motor
commands always sum to zero (the mix columns are orthogonal to (1, 1, 1, 1)), and the allocation's
null space is (1, 1, 1, 1) too. So the thruster forces are ``f = pinv(T) tau + s 1``, the one
unknown ``s`` fixed by ``sum_i m(f_i) = 0`` with ``m`` the normalised pulse of the inverse T200
curve, a monotone equation solved by :func:`~auv_hinf.numerics.bisection.bisect`. Then
``q = M^T m / 4`` and the sticks follow, up to the dead band and the 1 us resolution of the pulses.

The assumptions, each a condition of this model (sources in docs/deployment.md):

* mode MANUAL (custom_mode 19): the only mode in which x, y **and** r drive the thrusters open loop;
  in STABILIZE and ALT_HOLD, r is a yaw-rate set-point of ArduSub's attitude controller (and z a
  climb rate in ALT_HOLD);
* FRAME_CONFIG = 2 (Vectored_6DOF, the Heavy), with the motor directions set so that a positive
  motor command gives the T200's forward thrust along the allocation's direction;
* the pilot gain ``gain`` (JS_GAIN_DEFAULT 0.5 at boot, 0.1-1.0; reported as NAMED_VALUE_FLOAT
  "PilotGain"), JS_THR_GAIN 1, ACRO_YAW_P as given, RC1-6 MIN/TRIM/MAX 1100/1500/1900 and
  MOT_PWM_MIN/MAX 1100/1900 (ArduSub's defaults);
* no buttons, roll and pitch neutral, vertical thrusters idle (z = 500).

The geometry is the package's :func:`~auv_hinf.actuation.thrusters.bluerov2_heavy_thrusters`, its
thrusters 1-4 being ArduSub's motors 1-4 (front right, front left, rear right, rear left); the
mapping checks that its allocation rows are the mix columns up to positive scales.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrusters import ThrusterAllocation, bluerov2_heavy_thrusters, box_corners
from auv_hinf.deployment.thrust_curve import PWM_NEUTRAL, T200Curve
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.numerics.bisection import bisect

#: ArduSub's Vectored_6DOF horizontal factors of motors 1-4, columns (yaw, forward, lateral)
#: (AP_Motors6DOF.cpp, SUB_FRAME_VECTORED_6DOF).
VECTORED_6DOF_MIX = np.array([[1.0, -1.0, 1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, -1.0]])
#: ArduSub's default ACRO_YAW_P (config.h): MANUAL scales the yaw input by ACRO_YAW_P over it.
ACRO_YAW_P_DEFAULT = 3.375
#: ArduSub custom_mode numbers (mode.h).
MODE_STABILIZE, MODE_ALT_HOLD, MODE_GUIDED, MODE_MANUAL = 0, 2, 4, 19
#: The pilot gain's range (JS_GAIN_MIN/MAX bounds in Parameters.cpp, clamped in joystick.cpp).
GAIN_RANGE = (0.1, 1.0)
#: RC pulse per stick count at gain 1 (us): ``rpyScale = 0.4 gain`` (joystick.cpp).
RPY_SCALE = 0.4
#: Half-range of the RC and motor pulses (us): 1500 +- 400.
PULSE_HALF_RANGE = 400.0
#: Largest stick value of MANUAL_CONTROL x, y, r.
STICK_MAX = 1000
#: MANUAL_CONTROL z that leaves the vertical thrusters idle.
Z_NEUTRAL = 500
#: Bisection steps of the null-space shift ``s`` (N): 60 halvings take a bracket of a few hundred
#: N below 1e-15 N, under the curve's own resolution.
SHIFT_STEPS = 60
#: Relative width at which :meth:`ArduSubMapping.largest_box_scale` stops.
BOX_SCALE_RTOL = 1e-3
#: RC pulse offsets tried around the wanted ones (us), per axis: the eight corners of the unit cube.
_NEIGHBOURS = np.array([[a, b, c] for a in (0.0, 1.0) for b in (0.0, 1.0) for c in (0.0, 1.0)])
#: Rows of the allocation and columns of the mix must be parallel to this (cosine), after scaling.
PARALLEL_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ManualCommand:
    """One MANUAL_CONTROL command and what it is predicted to do.

    Attributes
    ----------
    x, y, z, r : int
        The axes: x forward, y lateral (starboard), r yaw in [-1000, 1000]; z in [0, 1000], 500
        neutral (vertical thrusters idle).
    achieved : tuple of float
        Body force predicted for these sticks (N, N, N m), through the vehicle's side of the mapping.
    saturated : bool
        A thruster, the mixer or a stick had to be clipped: the force asked for is not deliverable.
    """

    x: int
    y: int
    z: int
    r: int
    achieved: tuple[float, float, float] = (0.0, 0.0, 0.0)
    saturated: bool = False

    @property
    def normalised(self) -> tuple[float, float, float, float]:
        """``(x, y, z, r) / 1000``: the normalised command MAVLink carries."""
        return (self.x / 1000.0, self.y / 1000.0, self.z / 1000.0, self.r / 1000.0)


#: The neutral command: no horizontal thrust, vertical thrusters idle.
NEUTRAL = ManualCommand(0, 0, Z_NEUTRAL, 0)


def _check_allocation(thrusters: ThrusterAllocation) -> FloatArray:
    """The allocation matrix of ``thrusters``, checked against the Vectored_6DOF mix (module docstring)."""
    if thrusters.count != 4:
        raise ParameterError(
            f"the ArduSub Vectored_6DOF mapping drives four horizontal thrusters, got {thrusters.count}"
        )
    mat = thrusters.matrix()
    for row, col, name in ((0, 1, "surge"), (1, 2, "sway"), (2, 0, "yaw")):
        a, b = mat[row], VECTORED_6DOF_MIX[:, col]
        cosine = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
        if cosine < 1.0 - PARALLEL_TOLERANCE:
            raise ParameterError(
                f"the thrusters' {name} row {np.round(a, 4).tolist()} is not the Vectored_6DOF mix column "
                f"{b.tolist()} up to a positive scale: the thruster order or directions differ from "
                "ArduSub's motors 1-4"
            )
    return mat


@dataclass(frozen=True)
class ArduSubMapping:
    """The vehicle settings behind the MANUAL_CONTROL to force map (module docstring).

    Parameters
    ----------
    gain : float
        ArduSub's pilot (joystick) gain in [0.1, 1.0]. ArduSub boots at JS_GAIN_DEFAULT (0.5);
        1.0 gives full authority (1500 +- 400 us at full stick).
    voltage : float
        Thruster supply voltage (V, 12-20).
    acro_yaw_p : float
        The vehicle's ACRO_YAW_P (> 0; its default 3.375 makes the MANUAL yaw factor 1).
    thrusters : ThrusterAllocation
        The horizontal thrusters, in ArduSub's motor order (default: the BlueROV2 Heavy's).

    Attributes
    ----------
    curve : T200Curve
        The thrust curve at ``voltage`` (derived).
    matrix : ndarray, shape (3, 4)
        The thrusters' allocation matrix: body force and moment per unit thrust (derived).

    Raises
    ------
    ParameterError
        For a gain outside [0.1, 1.0], a voltage outside the T200 table, ``acro_yaw_p <= 0``, or
        thrusters that are not ArduSub's four Vectored_6DOF motors.
    """

    gain: float = 1.0
    voltage: float = 16.0
    acro_yaw_p: float = ACRO_YAW_P_DEFAULT
    thrusters: ThrusterAllocation = field(default_factory=bluerov2_heavy_thrusters)
    curve: T200Curve = field(init=False, repr=False, compare=False)
    matrix: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        g = require_finite("pilot gain", self.gain)
        if not GAIN_RANGE[0] <= g <= GAIN_RANGE[1]:
            raise ParameterError(f"ArduSub pilot gain must be in [0.1, 1.0] (the JS_GAIN range), got {g!r}")
        if not require_finite("ACRO_YAW_P", self.acro_yaw_p) > 0.0:
            raise ParameterError(f"ACRO_YAW_P must be > 0, got {self.acro_yaw_p!r}")
        object.__setattr__(self, "gain", g)
        object.__setattr__(self, "curve", T200Curve(self.voltage))
        object.__setattr__(self, "matrix", _check_allocation(self.thrusters))

    @property
    def yaw_scale(self) -> float:
        """MANUAL's yaw factor ``ACRO_YAW_P / 3.375``."""
        return float(self.acro_yaw_p) / ACRO_YAW_P_DEFAULT

    @property
    def stick_pulse(self) -> float:
        """RC pulse per stick count (us): ``0.4 gain``, with the gain as ArduSub's float holds it."""
        return RPY_SCALE * float(np.float32(self.gain))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe description (stored in run logs)."""
        return {
            "gain": self.gain,
            "voltage": float(self.voltage),
            "acro_yaw_p": float(self.acro_yaw_p),
            "mode": MODE_MANUAL,
            "thrusters": self.thrusters.name,
        }

    # ---- the vehicle's side --------------------------------------------------------------------
    def normalised_inputs(self, x: ArrayLike, y: ArrayLike, r: ArrayLike) -> FloatArray:
        """ArduSub's normalised (forward, lateral, yaw) inputs from stick values, shape ``(..., 3)``.

        Parameters
        ----------
        x, y, r : array_like
            MANUAL_CONTROL forward, lateral and yaw sticks in [-1000, 1000].

        Returns
        -------
        ndarray
            ``q`` in [-1, 1] per axis (the yaw already times :attr:`yaw_scale`).
        """
        ch = [np.clip(np.trunc(np.asarray(a, dtype=float) * self.stick_pulse + 1500.0), 1100, 1900) for a in (x, y, r)]
        q = np.stack([(c - 1500.0) / PULSE_HALF_RANGE for c in ch], axis=-1)
        q[..., 2] *= self.yaw_scale
        return q

    def motor_commands(self, q: ArrayLike) -> FloatArray:
        """Vectored_6DOF commands of motors 1-4 in [-1, 1] from ``q = (forward, lateral, yaw)``.

        Parameters
        ----------
        q : array_like, shape (..., 3)
            Normalised inputs, as :meth:`normalised_inputs` gives them.

        Returns
        -------
        ndarray, shape (..., 4)
            The mixed commands, scaled down together when one exceeds 1.
        """
        qq = np.asarray(q, dtype=float)
        yfl = np.einsum("mk,...k->...m", VECTORED_6DOF_MIX, qq[..., [2, 0, 1]])
        norm = np.maximum(1.0, np.max(np.abs(yfl), axis=-1, keepdims=True))
        out: FloatArray = np.clip(yfl / norm, -1.0, 1.0)
        return out

    def motor_pwm(self, m: ArrayLike) -> FloatArray:
        """Motor pulse widths (us) of motor commands ``m``: ``trunc(1500 + 400 m)``.

        Parameters
        ----------
        m : array_like
            Motor commands in [-1, 1].

        Returns
        -------
        ndarray
            Pulse widths (us), the shape of ``m``.
        """
        out: FloatArray = np.trunc(PWM_NEUTRAL + PULSE_HALF_RANGE * np.asarray(m, dtype=float))
        return out

    def manual_control_to_forces(self, x: ArrayLike, y: ArrayLike, r: ArrayLike) -> FloatArray:
        """Body force the vehicle makes for stick values ``x, y, r``, shape ``(..., 3)`` (N, N, N m).

        Parameters
        ----------
        x, y, r : array_like
            MANUAL_CONTROL forward, lateral and yaw sticks in [-1000, 1000] (broadcast together).

        Returns
        -------
        ndarray
            ``(tau_x, tau_y, tau_psi)``; z plays no part (the vertical thrusters have no horizontal share).
        """
        pwm = self.motor_pwm(self.motor_commands(self.normalised_inputs(x, y, r)))
        out: FloatArray = np.einsum("km,...m->...k", self.matrix, self.curve.thrust(pwm))
        return out

    # ---- the controller's side -----------------------------------------------------------------
    def _pulse(self, f: FloatArray) -> FloatArray:
        """Normalised motor pulse ``(pwm - 1500) / 400`` that gives thrusts ``f`` (N)."""
        out: FloatArray = (self.curve.pwm(f) - PWM_NEUTRAL) / PULSE_HALF_RANGE
        return out

    def forces_to_manual_control(self, tau: ArrayLike) -> ManualCommand:
        """The MANUAL_CONTROL sticks for the body force ``tau`` of one vehicle.

        Parameters
        ----------
        tau : array_like, shape (3,)
            ``(tau_x, tau_y, tau_psi)`` (N, N, N m).

        Returns
        -------
        ManualCommand
            ``x, y, r`` in [-1000, 1000], ``z = 500``, the force predicted for them and whether
            anything had to be clipped.

        Raises
        ------
        ParameterError
            If ``tau`` is not three finite numbers.
        """
        t = np.asarray(tau, dtype=float)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ParameterError(f"a body force is three finite numbers (N, N, N m), got {tau!r}")
        if not np.any(t):
            return NEUTRAL
        f0 = np.linalg.pinv(self.matrix) @ t
        reach = self.curve.forward_max + self.curve.reverse_max + float(np.max(np.abs(f0)))

        def below(s: float) -> bool:  # the pulse sum is increasing in the shift s
            return float(np.sum(self._pulse(f0 + s))) <= 0.0

        lo, hi = bisect(below, -reach, reach, steps=SHIFT_STEPS)
        s = lo if abs(np.sum(self._pulse(f0 + lo))) <= abs(np.sum(self._pulse(f0 + hi))) else hi
        f = f0 + s
        saturated = bool(np.any(f > self.curve.forward_max) or np.any(-f > self.curve.reverse_max))
        q = VECTORED_6DOF_MIX.T @ self._pulse(f) / 4.0  # (yaw, forward, lateral)
        want = np.array([q[1], q[2], q[0] / self.yaw_scale]) * PULSE_HALF_RANGE  # RC pulse offsets (us)
        # the vehicle's pulses are whole microseconds: try the offsets next to the wanted ones and
        # keep the sticks whose force is closest, the moment weighted by the allocation's arm
        offsets = np.floor(want)[None, :] + _NEIGHBOURS
        sticks = np.where(offsets == 0, 0, np.round((offsets + 0.5) / self.stick_pulse))
        clipped = np.abs(sticks) > STICK_MAX
        sticks = np.clip(sticks, -STICK_MAX, STICK_MAX)
        made = self.manual_control_to_forces(sticks[:, 0], sticks[:, 1], sticks[:, 2])
        weight = np.array([1.0, 1.0, self.moment_weight])
        best = int(np.argmin(np.sum(((made - t) * weight) ** 2, axis=1)))
        x, y, r = (int(v) for v in sticks[best])
        saturated = saturated or bool(clipped[best].any())
        if np.max(np.abs(VECTORED_6DOF_MIX @ self.normalised_inputs(x, y, r)[[2, 0, 1]])) > 1.0:
            saturated = True  # the mixer scales every motor down
        a = made[best]
        return ManualCommand(x, y, Z_NEUTRAL, r, (float(a[0]), float(a[1]), float(a[2])), saturated)

    @property
    def moment_weight(self) -> float:
        """N per N m at the thrusters: the allocation's force row norm over its yaw row norm (1/m)."""
        return float(np.linalg.norm(self.matrix[0]) / np.linalg.norm(self.matrix[2]))

    def delivers_box(self, peak: ArrayLike) -> bool:
        """Whether every corner of the force box ``|tau_k| <= peak_k`` maps through MANUAL_CONTROL unclipped.

        Parameters
        ----------
        peak : array_like, shape (3,)
            Half-widths ``(peak_x, peak_y, peak_psi)`` >= 0 (N, N, N m).

        Returns
        -------
        bool
            No corner saturates a thruster, the mixer or a stick. Unlike
            :meth:`~auv_hinf.actuation.thrusters.ThrusterAllocation.contains_box` this is a corner
            test of a map with a dead band and 1 us pulses, not a proof for the whole box.
        """
        return not any(self.forces_to_manual_control(c).saturated for c in box_corners(peak))

    def largest_box_scale(self, peak: ArrayLike, hi: float = 4.0) -> float:
        """Largest ``s`` (to :data:`BOX_SCALE_RTOL`) with the box ``|tau_k| <= s peak_k`` unclipped at its corners.

        Parameters
        ----------
        peak : array_like, shape (3,)
            Box half-widths >= 0, not all zero (N, N, N m).
        hi : float
            Upper end of the search (> 0); returned when even that scale is deliverable.

        Returns
        -------
        float
            The scale, by :func:`~auv_hinf.numerics.bisection.bisect` on :meth:`delivers_box`
            (compare :meth:`~auv_hinf.actuation.thrusters.ThrusterAllocation.largest_box_scale`,
            which lets the thrusters share the load freely).
        """
        p = np.asarray(peak, dtype=float)
        if not np.any(p > 0):
            raise ParameterError(f"peak must have a positive channel, got {p.tolist()}")
        if self.delivers_box(hi * p):
            return float(hi)
        lo = 1e-6
        if not self.delivers_box(lo * p):
            return 0.0
        return bisect(lambda s: self.delivers_box(s * p), lo, float(hi), rtol=BOX_SCALE_RTOL, geometric=True)[0]


__all__ = [
    "ACRO_YAW_P_DEFAULT",
    "BOX_SCALE_RTOL",
    "GAIN_RANGE",
    "MODE_ALT_HOLD",
    "MODE_GUIDED",
    "MODE_MANUAL",
    "MODE_STABILIZE",
    "NEUTRAL",
    "PARALLEL_TOLERANCE",
    "PULSE_HALF_RANGE",
    "RPY_SCALE",
    "SHIFT_STEPS",
    "STICK_MAX",
    "VECTORED_6DOF_MIX",
    "Z_NEUTRAL",
    "ArduSubMapping",
    "ManualCommand",
]
