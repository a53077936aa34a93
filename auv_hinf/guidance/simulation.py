"""A fleet of propeller-and-rudder vehicles under the guidance cascade, on the 3-DOF model.

Every vehicle runs :func:`~auv_hinf.guidance.law.commands` on its own slot, with its own
navigation and a shared clock, and no link to the others. Its navigation may be late and noisy
(:class:`Navigation`): the commands held from ``t_k`` are computed from the state measured at
``t_k - d`` (the start before ``t = 0``), against the slot at that time, with errors drawn within
the ``[implementation.noise]`` bounds by :class:`~auv_hinf.implementation.draws.ImplementationDraws`
(position, heading, body velocity and yaw rate; the DVL's ground velocity carries the body
velocity's error turned to the earth). The recorded errors are the true ones. The plant is the 3-DOF model
(:func:`~auv_hinf.models.vehicle.rhs`) with the forces the limited thrust and rudder make, in a
constant current. The integrator is classical RK4 at a fixed step (:data:`STEP`), the forces of
the thrust and rudder held over the step as computed at its start: the cascade as a 10 Hz
autopilot runs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.exceptions import ParameterError
from auv_hinf.guidance.law import Commands, GuidanceConfig, SlotMotion, commands, integral_start
from auv_hinf.implementation.draws import ImplementationDraws
from auv_hinf.implementation.model import Implementation
from auv_hinf.mission.fleet import FleetReference, wrap_angle
from auv_hinf.mission.separation import closest_approach
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams, rhs

#: Integration and control step (s): a 10 Hz autopilot, a tenth of the fastest time constant of
#: the default loop (the 1 s of the heading loop; the sway and surge dynamics are slower).
STEP = 0.1


def cascade_period(impl: Implementation) -> float:
    """The cascade's control period (s): the ``[implementation] sample_time``, or :data:`STEP` when none is declared.

    Parameters
    ----------
    impl : Implementation
        The configuration's implementation.
    """
    return impl.sample_time if impl.sample_time > 0.0 else STEP


#: Units of the figures of :meth:`GuidanceRun.report` (the text of ``simulate``).
REPORT_UNITS: dict[str, Any] = {
    "commanded_peak": {"force_x": "N", "rudder": "rad"},
    "delivered_peak": {"force_x": "N", "rudder": "rad"},
    "limits": {"force_x": "N", "rudder": "rad"},
    "measured_errors": {"along_track": "m", "cross_track": "m", "heading": "rad"},
    "certified_errors": {"along_track": "m", "cross_track": "m", "heading": "rad"},
    "certified_peak": {"force_x": "N", "rudder": "rad"},
    "final_errors": {"along_track": "m", "cross_track": "m", "heading": "rad", "after": "s"},
    "saturation_fraction": "of the samples (some vehicle's thrust or rudder at its limit)",
    "peak_sway_speed": "m/s",
    "min_separation": "m",
    "first_exit_time": "s",
    "horizon": "s",
    "sample_time": "s",
    "delay": "s",
    "noise": {"position": "m", "velocity": "m/s", "heading": "rad", "yaw_rate": "rad/s"},
    "vertical": {"depth": "m", "peak_roll": "rad", "peak_pitch": "rad"},
}
#: Relative tolerance on the limits below which a command counts as saturated (rounding only).
SATURATION_RTOL = 1e-9


@dataclass(frozen=True)
class Navigation:
    """How late and how noisy every vehicle's measurement is (the ``[implementation]`` of a guidance fleet).

    Attributes
    ----------
    delay : float
        Age (s) of the measurement the commands are computed from (fixed).
    implementation : Implementation or None
        The noise bounds (``None`` or exact: no noise).
    seed : int
        Seed of the noise draws.
    pattern : str
        The noise pattern (:data:`~auv_hinf._typing.NOISE_PATTERNS`).
    """

    delay: float = 0.0
    implementation: Implementation | None = None
    seed: int = 0
    pattern: str = "uniform"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.delay) and self.delay >= 0.0):
            raise ParameterError(f"the navigation delay must be >= 0 s, got {self.delay!r}")

    @property
    def noisy(self) -> bool:
        """Some measurement error bound is positive."""
        return self.noise is not None

    @property
    def noise(self) -> dict[str, float] | None:
        """The error bounds ``{position, velocity, heading, yaw_rate}`` (m, m/s, rad, rad/s); ``None``: exact."""
        impl = self.implementation
        return None if impl is None or impl.noise.exact else impl.noise.to_dict()


#: Exact, undelayed navigation (what the cascade measured before ``[implementation]`` delay and noise).
EXACT = Navigation()


@dataclass(frozen=True)
class GuidanceRun:
    """One simulated run of the cascade.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Times (s).
    states : ndarray, shape (T, N, 6)
        ``[x, y, psi, u, v, r]`` of every vehicle.
    integral : ndarray, shape (T, N)
        ILOS states (s).
    thrust_cmd, rudder_cmd, thrust, rudder : ndarray, shape (T, N)
        Commanded and delivered thrust (N) and rudder (rad).
    along_track, cross_track, heading_error : ndarray, shape (T, N)
        Errors (m, m, rad).
    slots : ndarray, shape (T, N, 2)
        The slots' positions (m).
    act : RudderActuation
        The limits the run used.
    vertical : ndarray, shape (T, N, 3) or None
        ``[z, phi, theta]`` (m, rad, rad) of a 6-DOF plant (:mod:`auv_hinf.guidance.six_dof`);
        ``None`` on the 3-DOF model.
    navigation : Navigation
        The measurement's delay and noise the run used.
    """

    t: FloatArray
    states: FloatArray
    integral: FloatArray
    thrust_cmd: FloatArray
    rudder_cmd: FloatArray
    thrust: FloatArray
    rudder: FloatArray
    along_track: FloatArray
    cross_track: FloatArray
    heading_error: FloatArray
    slots: FloatArray
    act: RudderActuation
    vertical: FloatArray | None = None
    navigation: Navigation = EXACT

    @property
    def saturated(self) -> np.ndarray:
        """``(T,)``: some vehicle's thrust or rudder is at its limit."""
        thrust = np.abs(self.thrust_cmd) > self.act.tau_x * (1.0 + SATURATION_RTOL)
        rudder = np.abs(self.rudder_cmd) > self.act.rudder_max * (1.0 + SATURATION_RTOL)
        return np.asarray(np.any(thrust | rudder, axis=1))

    def min_separation(self) -> tuple[float, tuple[int, int]]:
        """The smallest distance between two vehicles over the run (m) and the pair (0-based)."""
        if self.states.shape[1] < 2:
            return float("inf"), (0, 0)
        # blocks of samples for a small fleet, a k-d tree per sample for a large one: memory O(N), not O(T N^2)
        closest = closest_approach(self.states[:, :, :2])
        return closest.distance, closest.pair

    def _vertical_report(self) -> dict[str, Any]:
        """Depth range (m), peak roll and pitch (rad) of a 6-DOF run."""
        v = self.vertical if self.vertical is not None else np.zeros((1, 1, 3))
        return {
            "depth": [float(v[..., 0].min()), float(v[..., 0].max())],
            "peak_roll": float(np.abs(v[..., 1]).max()),
            "peak_pitch": float(np.abs(v[..., 2]).max()),
        }

    def envelope_exit(self, envelope: Envelope) -> float | None:
        """The first time (s) some vehicle's ``(u, v, r)`` is outside ``envelope``; ``None``: never.

        Parameters
        ----------
        envelope : Envelope
            The declared ``[envelope]`` (its heading range is not checked: the heading is the full circle).
        """
        s = self.states
        inside = envelope.contains(s[:, :, 3], s[:, :, 4], s[:, :, 5]).all(axis=1)
        out = np.flatnonzero(~inside)
        return float(self.t[out[0]]) if out.size else None

    def report(self, settle: float = 0.5, envelope: Envelope | None = None) -> dict[str, Any]:
        """The ``simulate --json`` figures of the run (SI units; vehicles 0-based).

        Parameters
        ----------
        settle : float
            Fraction of the horizon after which the ``final_errors`` are measured (0-1).
        envelope : Envelope or None
            The declared ``[envelope]``: ``stayed_in_envelope`` and ``first_exit_time`` say whether
            and when the run left it (both ``None`` without one).
        """
        tail = self.t >= self.t[-1] * settle
        sep, pair = self.min_separation()
        exit_time = None if envelope is None else self.envelope_exit(envelope)

        def worst(x: FloatArray) -> float:
            return float(np.max(np.abs(x))) if x.size else 0.0

        return {
            "law": "guidance",
            "commanded_peak": {"force_x": worst(self.thrust_cmd), "rudder": worst(self.rudder_cmd)},
            "delivered_peak": {"force_x": worst(self.thrust), "rudder": worst(self.rudder)},
            "limits": {"force_x": self.act.tau_x, "rudder": self.act.rudder_max},
            "saturation_fraction": float(np.mean(self.saturated)),
            "measured_errors": {
                "along_track": worst(self.along_track),
                "cross_track": worst(self.cross_track),
                "heading": worst(self.heading_error),
            },
            "final_errors": {
                "along_track": worst(self.along_track[tail]),
                "cross_track": worst(self.cross_track[tail]),
                "heading": worst(self.heading_error[tail]),
                "after": float(self.t[-1] * settle),
            },
            "peak_sway_speed": worst(self.states[:, :, 4]),
            "min_separation": sep,
            "closest_pair": list(pair),
            "stayed_in_envelope": None if envelope is None else exit_time is None,
            "first_exit_time": exit_time,
            "horizon": float(self.t[-1]),
            "sample_time": float(self.t[1] - self.t[0]) if self.t.size > 1 else None,
            "delay": self.navigation.delay,
            "noise": self.navigation.noise,
            "noise_pattern": self.navigation.pattern if self.navigation.noisy else None,
            **({} if self.vertical is None else {"vertical": self._vertical_report()}),
        }


def _true_errors(view: FloatArray, slot: SlotMotion) -> FloatArray:
    """``[ex, ey, epsi, eu, ev, er]`` of every vehicle against its slot: the ``against-error`` pattern's input.

    The position error (inertial), the heading less the slot's course, the body velocity less the
    slot's ground velocity turned into the body frame, and the yaw rate less the course rate.
    """
    psi = view[:, 2]
    course = np.arctan2(slot.v[:, 1], slot.v[:, 0])
    cs, sn = np.cos(psi), np.sin(psi)
    du = view[:, 3] - (cs * slot.v[:, 0] + sn * slot.v[:, 1])
    dv = view[:, 4] - (-sn * slot.v[:, 0] + cs * slot.v[:, 1])
    return np.stack(
        [
            view[:, 0] - slot.p[:, 0],
            view[:, 1] - slot.p[:, 1],
            wrap_angle(psi - course),
            du,
            dv,
            view[:, 5] - slot.course_rate,
        ],
        axis=-1,
    )


def slot_motion(ref: FleetReference, t: FloatArray) -> SlotMotion:
    """The slots' motion at times ``t (T,)`` (s), shape ``(T, N, 2)``, in one vectorised evaluation.

    Parameters
    ----------
    ref : FleetReference
        The fleet's desired motion.
    t : ndarray, shape (T,)
        Times (s).
    """
    (p, v, a, _), _ = ref.kinematics(np.asarray(t, dtype=float))
    return SlotMotion(p=p, v=v, a=a)


def slot_start(slot: SlotMotion, current: FloatArray) -> FloatArray:
    """States ``(N, 6)`` on the slots, heading into the current so the ground velocity is the slot's.

    Parameters
    ----------
    slot : SlotMotion
        The slots at the start.
    current : ndarray, shape (2,)
        The current (m/s, inertial).
    """
    water = slot.v - current  # velocity through the water that gives the slot's ground velocity
    n = slot.p.shape[0]
    out = np.zeros((n, 6))
    out[:, :2] = slot.p
    out[:, 2] = np.arctan2(water[:, 1], water[:, 0])
    out[:, 3] = np.hypot(water[:, 0], water[:, 1])
    return out


def simulate_guidance(
    gcfg: GuidanceConfig,
    plant: VehicleParams,
    model: VehicleParams,
    act: RudderActuation,
    ref: FleetReference,
    horizon: float,
    current: tuple[float, float] = (0.0, 0.0),
    initial: FloatArray | None = None,
    step: float = STEP,
    plant_act: RudderActuation | None = None,
    navigation: Navigation = EXACT,
) -> GuidanceRun:
    """Simulate the fleet under the cascade for ``horizon`` s.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance and autopilot gains.
    plant : VehicleParams
        The true vehicle.
    model : VehicleParams
        The controller's model of it.
    act : RudderActuation
        The controller's propeller and rudder figures (and the limits).
    ref : FleetReference
        The slots' desired motion.
    horizon : float
        Length of the run (s, > 0).
    current : tuple of float
        Constant current (m/s, inertial).
    initial : ndarray, shape (N, 6), optional
        Start states; default on the slots, heading into the current.
    step : float
        Integration and control step (s).
    plant_act : RudderActuation, optional
        The true rudder derivatives (default: ``act``).
    navigation : Navigation
        The measurement's delay and noise (default exact and undelayed).

    Raises
    ------
    ParameterError
        If the horizon or step is not positive, or ``initial`` has the wrong shape.
    """
    true_act = act if plant_act is None else plant_act
    three_dof = ThreeDofPlant(plant, true_act, np.asarray(current, dtype=float))
    return run_cascade(gcfg, model, act, ref, horizon, three_dof, initial, step, navigation)


class GuidancePlant(Protocol):
    """What :func:`run_cascade` needs of a plant: its start, horizontal view, ground velocity and derivative."""

    @property
    def current(self) -> FloatArray:
        """The constant current (m/s, inertial), shape (2,)."""
        ...

    def start(self, horizontal: FloatArray) -> FloatArray:
        """The full state of every vehicle from ``[x, y, psi, u, v, r]`` per vehicle ``(N, 6)``.

        Parameters
        ----------
        horizontal : ndarray, shape (N, 6)
            ``[x, y, psi, u, v, r]`` per vehicle.
        """
        ...

    def horizontal(self, state: FloatArray) -> FloatArray:
        """``[x, y, psi, u, v, r]`` per vehicle ``(N, 6)`` of the full state: what the cascade measures.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        ...

    def ground(self, state: FloatArray) -> FloatArray:
        """The ground velocity ``(N, 2)`` (m/s, inertial): what a DVL's bottom track measures.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        ...

    def derivative(self, state: FloatArray, cmd: Commands) -> FloatArray:
        """The time derivative of the full state under the delivered thrust and rudder of ``cmd``.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        cmd : Commands
            The cascade's commands; their delivered thrust and rudder act.
        """
        ...

    def vertical(self, state: FloatArray) -> FloatArray | None:
        """``[z, phi, theta]`` per vehicle ``(N, 3)``, or ``None`` for a plant in the plane.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        ...


@dataclass(frozen=True)
class ThreeDofPlant:
    """The 3-DOF model (:func:`~auv_hinf.models.vehicle.rhs`) in a constant current; states ``[x, y, psi, u, v, r]``.

    Attributes
    ----------
    params : VehicleParams
        The true vehicle.
    act : RudderActuation
        The true propeller and rudder (their derivatives make the forces).
    current : ndarray, shape (2,)
        Constant current (m/s, inertial).
    """

    params: VehicleParams
    act: RudderActuation
    current: FloatArray

    def start(self, horizontal: FloatArray) -> FloatArray:
        """``horizontal`` itself (see :class:`GuidancePlant`).

        Parameters
        ----------
        horizontal : ndarray, shape (N, 6)
            ``[x, y, psi, u, v, r]`` per vehicle.
        """
        return np.array(horizontal, dtype=float)

    def horizontal(self, state: FloatArray) -> FloatArray:
        """``state`` itself.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        return state

    def ground(self, state: FloatArray) -> FloatArray:
        """The body velocity turned to the earth, plus the current.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        c = self.current
        cs, sn = np.cos(state[:, 2]), np.sin(state[:, 2])
        u, v = state[:, 3], state[:, 4]
        return np.stack([cs * u - sn * v + c[0], sn * u + cs * v + c[1]], axis=-1)

    def derivative(self, state: FloatArray, cmd: Commands) -> FloatArray:
        """:func:`~auv_hinf.models.vehicle.rhs` with the forces of ``cmd``, and the current on the position.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        cmd : Commands
            The cascade's commands; their delivered thrust and rudder act.
        """
        d = rhs(self.params, state, cmd.body_forces(self.act, state[:, 3]))
        d[:, 0:2] += self.current
        return d

    def vertical(self, state: FloatArray) -> FloatArray | None:
        """``None``: the model is planar.

        Parameters
        ----------
        state : ndarray
            The full states of the fleet, one row per vehicle.
        """
        return None


def run_cascade(
    gcfg: GuidanceConfig,
    model: VehicleParams,
    act: RudderActuation,
    ref: FleetReference,
    horizon: float,
    plant: GuidancePlant,
    initial: FloatArray | None = None,
    step: float = STEP,
    navigation: Navigation = EXACT,
) -> GuidanceRun:
    """Run the cascade at ``step`` on ``plant``.

    The controller acts every ``step`` s (its control period) on the plant's horizontal view
    measured ``navigation.delay`` s earlier (the start before ``t = 0``), with the navigation's
    errors, and holds its thrust and rudder over the step; the plant is integrated by RK4 in
    substeps of at most :data:`STEP`, split where a late measurement is taken.

    Parameters
    ----------
    gcfg : GuidanceConfig
        Guidance and autopilot gains.
    model : VehicleParams
        The controller's 3-DOF model of the vehicle.
    act : RudderActuation
        The controller's propeller and rudder figures (and the limits).
    ref : FleetReference
        The slots' desired motion.
    horizon : float
        Length of the run (s, > 0).
    plant : GuidancePlant
        The simulated vehicles (:class:`ThreeDofPlant`, or the 6-DOF plant of
        :mod:`auv_hinf.guidance.six_dof`).
    initial : ndarray, shape (N, 6), optional
        Horizontal start states; default on the slots, heading into the plant's current.
    step : float
        Control and integration step (s).
    navigation : Navigation
        The measurement's delay and noise (default exact and undelayed).

    Raises
    ------
    ParameterError
        If the horizon or step is not positive, ``initial`` has the wrong shape, or the run diverges.
    """
    if not (np.isfinite(horizon) and horizon > 0.0 and np.isfinite(step) and step > 0.0):
        raise ParameterError(f"horizon and step must be > 0 s, got {horizon!r} and {step!r}")
    n_steps = int(np.ceil(horizon / step))
    t = np.arange(n_steps + 1) * step
    slots = slot_motion(ref, t)
    # the measurement of sample k is taken at max(t_k - d, 0): d = lag_steps step + phase
    delay = navigation.delay
    lag_steps = math.floor(delay / step + 1e-9)
    phase = max(delay - lag_steps * step, 0.0)
    if phase <= 1e-9 * step:
        phase = 0.0
    seen = slot_motion(ref, np.maximum(t - delay, 0.0)) if delay > 0.0 else slots

    def at(s: SlotMotion, k: int) -> SlotMotion:
        return SlotMotion(p=s.p[k], v=s.v[k], a=s.a[k])

    slot0 = at(slots, 0)
    n = slot0.p.shape[0]
    start = slot_start(slot0, plant.current) if initial is None else np.array(initial, dtype=float)
    if start.shape != (n, 6) or not np.all(np.isfinite(start)):
        raise ParameterError(f"initial states must be finite with shape ({n}, 6), got {start.shape}")
    x = plant.start(start)
    yi = integral_start(gcfg, plant.horizontal(x), slot0)
    impl = navigation.implementation
    draws = (
        ImplementationDraws(impl, [navigation.seed], n, [navigation.pattern])
        if navigation.noisy and impl is not None
        else None
    )
    # what each later sample measures: (view, ground velocity), by sample index
    measured: dict[int, tuple[FloatArray, FloatArray]] = {}
    first = (plant.horizontal(x).copy(), plant.ground(x).copy())

    def rk4(x: FloatArray, cmd: Commands, span: float) -> FloatArray:
        # RK4 with the forces held (the autopilot's zero-order hold), in substeps of at most STEP
        parts = max(1, math.ceil(span / STEP - 1e-9))
        h = span / parts
        for _ in range(parts):
            k1 = plant.derivative(x, cmd)
            k2 = plant.derivative(x + 0.5 * h * k1, cmd)
            k3 = plant.derivative(x + 0.5 * h * k2, cmd)
            k4 = plant.derivative(x + h * k3, cmd)
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return x

    keys = ("x", "yi", "tc", "rc", "th", "rd", "xe", "ye", "eh", "sl", "vt")
    rec: dict[str, list[FloatArray]] = {k: [] for k in keys}
    for k in range(n_steps + 1):
        slot = at(slots, k)
        view, ground = plant.horizontal(x), plant.ground(x)
        if phase == 0.0:
            measured[k + lag_steps] = (view.copy(), ground.copy())
        truth = commands(gcfg, model, act, view, yi, slot, ground)  # the errors as they are
        seen_view, seen_ground = measured.pop(k, first)  # none taken yet before t_k = d: the start
        if delay > 0.0 or draws is not None:
            if draws is not None:
                noise = draws.noise(k)[0]
                if navigation.pattern == "against-error":
                    noise = draws.against(_true_errors(seen_view, at(seen, k))[None])[0]
                cs, sn = np.cos(seen_view[:, 2]), np.sin(seen_view[:, 2])
                seen_view = seen_view + noise
                seen_ground = seen_ground + np.stack(
                    [cs * noise[:, 3] - sn * noise[:, 4], sn * noise[:, 3] + cs * noise[:, 4]], axis=-1
                )
            cmd = commands(gcfg, model, act, seen_view, yi, at(seen, k), seen_ground)
        else:
            cmd = truth
        vertical = plant.vertical(x)
        for key, val in (
            ("x", view), ("yi", yi), ("tc", cmd.thrust_cmd), ("rc", cmd.rudder_cmd), ("th", cmd.thrust),
            ("rd", cmd.rudder), ("xe", truth.along_track), ("ye", truth.cross_track), ("eh", truth.heading_error),
            ("sl", slot.p), ("vt", np.zeros((n, 3)) if vertical is None else vertical),
        ):  # fmt: skip
            rec[key].append(np.array(val, dtype=float))
        if k == n_steps:
            break
        # the ILOS state integrates its rate at the sample (Euler: the controller's own discrete
        # integrator); a late measurement's phase splits the step where it is taken
        if phase > 0.0:
            x = rk4(x, cmd, step - phase)
            measured[k + 1 + lag_steps] = (plant.horizontal(x).copy(), plant.ground(x).copy())
            x = rk4(x, cmd, phase)
        else:
            x = rk4(x, cmd, step)
        yi = yi + step * cmd.integral_rate
        if not np.all(np.isfinite(x)):
            raise ParameterError(f"the guidance run diverged at t = {t[k + 1]:.4g} s (a state is not finite)")
    arr = {k: np.stack(v) for k, v in rec.items()}
    return GuidanceRun(
        t=t,
        states=arr["x"],
        integral=arr["yi"],
        thrust_cmd=arr["tc"],
        rudder_cmd=arr["rc"],
        thrust=arr["th"],
        rudder=arr["rd"],
        along_track=arr["xe"],
        cross_track=arr["ye"],
        heading_error=arr["eh"],
        slots=arr["sl"],
        act=act,
        vertical=None if plant.vertical(x) is None else arr["vt"],
        navigation=navigation,
    )


__all__ = [
    "EXACT",
    "REPORT_UNITS",
    "SATURATION_RTOL",
    "STEP",
    "GuidancePlant",
    "GuidanceRun",
    "Navigation",
    "ThreeDofPlant",
    "cascade_period",
    "run_cascade",
    "simulate_guidance",
    "slot_motion",
    "slot_start",
]
