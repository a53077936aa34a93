"""A fleet of propeller-and-rudder vehicles under the guidance cascade, on the 3-DOF model.

Every vehicle runs :func:`~auv_hinf.guidance.law.commands` on its own slot, with its own
navigation (position, heading, body and ground velocity exact: this module does not model
sensor noise) and a shared clock, and no link to the others. The plant is the 3-DOF model
(:func:`~auv_hinf.models.vehicle.rhs`) with the forces the limited thrust and rudder make, in a
constant current. The integrator is classical RK4 at a fixed step (:data:`STEP`), the forces of
the thrust and rudder held over the step as computed at its start: the cascade as a 10 Hz
autopilot runs it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.exceptions import ParameterError
from auv_hinf.guidance.law import GuidanceConfig, SlotMotion, commands
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.vehicle import VehicleParams, rhs

#: Integration and control step (s): a 10 Hz autopilot, a tenth of the fastest time constant of
#: the default loop (the 1 s of the heading loop; the sway and surge dynamics are slower).
STEP = 0.1
#: Units of the figures of :meth:`GuidanceRun.report` (the text of ``simulate``).
REPORT_UNITS: dict[str, str] = {
    "commanded_peak": "N, rad",
    "delivered_peak": "N, rad",
    "limits": "N, rad",
    "measured_errors": "m, m, rad",
    "final_errors": "m, m, rad",
    "peak_sway_speed": "m/s",
    "min_separation": "m",
    "horizon": "s",
}
#: Relative tolerance on the limits below which a command counts as saturated (rounding only).
SATURATION_RTOL = 1e-9


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

    @property
    def saturated(self) -> np.ndarray:
        """``(T,)``: some vehicle's thrust or rudder is at its limit."""
        thrust = np.abs(self.thrust_cmd) > self.act.tau_x * (1.0 + SATURATION_RTOL)
        rudder = np.abs(self.rudder_cmd) > self.act.rudder_max * (1.0 + SATURATION_RTOL)
        return np.asarray(np.any(thrust | rudder, axis=1))

    def min_separation(self) -> tuple[float, tuple[int, int]]:
        """The smallest distance between two vehicles over the run (m) and the pair (0-based)."""
        n = self.states.shape[1]
        if n < 2:
            return float("inf"), (0, 0)
        p = self.states[:, :, :2]
        i, j = np.triu_indices(n, 1)
        d = np.hypot(p[:, i, 0] - p[:, j, 0], p[:, i, 1] - p[:, j, 1])
        k = int(np.argmin(d.min(axis=0)))
        return float(d[:, k].min()), (int(i[k]), int(j[k]))

    def report(self, settle: float = 0.5) -> dict[str, Any]:
        """The ``simulate --json`` figures of the run (SI units; vehicles 0-based).

        Parameters
        ----------
        settle : float
            Fraction of the horizon after which the ``final_errors`` are measured (0-1).
        """
        tail = self.t >= self.t[-1] * settle
        sep, pair = self.min_separation()

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
            "horizon": float(self.t[-1]),
            "certificate_covers_run": False,
        }


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

    Raises
    ------
    ParameterError
        If the horizon or step is not positive, or ``initial`` has the wrong shape.
    """
    if not (np.isfinite(horizon) and horizon > 0.0 and np.isfinite(step) and step > 0.0):
        raise ParameterError(f"horizon and step must be > 0 s, got {horizon!r} and {step!r}")
    true_act = act if plant_act is None else plant_act
    c = np.asarray(current, dtype=float)
    n_steps = int(np.ceil(horizon / step))
    t = np.arange(n_steps + 1) * step
    slots = slot_motion(ref, t)

    def at(k: int) -> SlotMotion:
        return SlotMotion(p=slots.p[k], v=slots.v[k], a=slots.a[k])

    slot0 = at(0)
    n = slot0.p.shape[0]
    x = slot_start(slot0, c) if initial is None else np.array(initial, dtype=float)
    if x.shape != (n, 6) or not np.all(np.isfinite(x)):
        raise ParameterError(f"initial states must be finite with shape ({n}, 6), got {x.shape}")
    yi = np.zeros(n)
    rec: dict[str, list[FloatArray]] = {k: [] for k in ("x", "yi", "tc", "rc", "th", "rd", "xe", "ye", "eh", "sl")}

    def ground(s: FloatArray) -> FloatArray:
        cs, sn = np.cos(s[:, 2]), np.sin(s[:, 2])
        return np.stack([cs * s[:, 3] - sn * s[:, 4] + c[0], sn * s[:, 3] + cs * s[:, 4] + c[1]], axis=-1)

    def deriv(s: FloatArray, forces: FloatArray) -> FloatArray:
        d = rhs(plant, s, forces)
        d[:, 0:2] += c
        return d

    for k in range(n_steps + 1):
        slot = at(k)
        cmd = commands(gcfg, model, act, x, yi, slot, ground(x))
        for key, val in (
            ("x", x), ("yi", yi), ("tc", cmd.thrust_cmd), ("rc", cmd.rudder_cmd), ("th", cmd.thrust),
            ("rd", cmd.rudder), ("xe", cmd.along_track), ("ye", cmd.cross_track), ("eh", cmd.heading_error),
            ("sl", slot.p),
        ):  # fmt: skip
            rec[key].append(np.array(val, dtype=float))
        if k == n_steps:
            break
        forces = cmd.body_forces(true_act, x[:, 3])
        # RK4 with the forces held over the step (the autopilot's zero-order hold); the ILOS state
        # integrates its rate at the sample (Euler: it is the controller's own discrete integrator).
        k1 = deriv(x, forces)
        k2 = deriv(x + 0.5 * step * k1, forces)
        k3 = deriv(x + 0.5 * step * k2, forces)
        k4 = deriv(x + step * k3, forces)
        x = x + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
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
    )


__all__ = ["REPORT_UNITS", "SATURATION_RTOL", "STEP", "GuidanceRun", "simulate_guidance", "slot_motion", "slot_start"]
