"""What a vehicle can push: per-channel force limits in the body frame, a rudder, and the saturation models.

:class:`Actuators` holds the largest body force ``|tau_x|`` (N), ``|tau_y|`` (N) and yaw
moment ``|tau_psi|`` (N m) the vehicle's propulsion gives, channel by channel. A certificate
bounds what the law commands over its whole certified set, as a box
``|tau_k| <= peak_k``; it is certified against the actuators only when that box lies inside
the feasible set (:meth:`Actuators.admits`). For per-channel limits the feasible set is itself
a box, so the test is exact channel by channel. With a thruster allocation
(:class:`~auv_hinf.actuation.thrusters.ThrusterAllocation`) the feasible set is a polytope and the
box is tested at its 8 corners, exact by convexity. The simulator applies
:meth:`Actuators.saturate` to the commanded forces; a certified run never reaches it.

A torpedo AUV (REMUS 100, Iver3, LAUV) has no such box: :class:`RudderActuation` is a propeller
(surge thrust) and a tail rudder whose deflection ``delta`` (rad) gives a sway force and a yaw
moment *together*, ``Y = Y_uu_delta u^2 delta`` and ``N = N_uu_delta u^2 delta``, at the surge
speed ``u``. The deliverable ``(tau_y, tau_psi)`` is a segment through the origin, so no box of
sway force and yaw moment with a nonzero width lies inside it: the fully actuated formation law,
which commands the two independently, is refused on such a vehicle, whatever its gains.

The vehicle presets' actuation, with its sources, is in :data:`VEHICLE_ACTUATORS` and
``docs/vehicles.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrusters import BENZON2022_THRUST, ThrusterAllocation, bluerov2_heavy_thrusters
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.numerics.integrators import FORCE_FLOOR

#: Channel names in the order of ``tau = (tau_x, tau_y, tau_psi)``, as the JSON reports them.
CHANNELS = ("force_x", "force_y", "moment")
#: Words for the channels in reasons.
CHANNEL_WORDS = {"force_x": "surge force", "force_y": "sway force", "moment": "yaw moment"}
#: Units of the channels.
CHANNEL_UNITS = {"force_x": "N", "force_y": "N", "moment": "N m"}
#: Units of the ``limits`` objects of either kind of actuation: the channels, and the rudder's deflection.
LIMIT_UNITS = {**CHANNEL_UNITS, "rudder": "rad"}
#: The two kinds of horizontal actuation (``[actuators] kind``): independent surge, sway and yaw
#: (:class:`Actuators`), or a propeller and a rudder (:class:`RudderActuation`).
ActuationKind = Literal["fully-actuated", "underactuated"]
ACTUATION_KINDS: tuple[ActuationKind, ...] = ("fully-actuated", "underactuated")
#: Largest rudder deflection accepted (rad): 45 degrees. Control fins stall near 20-25 degrees of
#: angle of attack; a larger figure is a unit mistake (degrees for radians) rather than a fin.
MAX_RUDDER = math.pi / 4
#: Relative tolerance under which a delivered force counts as the commanded one (-): the rudder's
#: forces are products ``c u^2 delta`` whose rounding is a few ulps, far below this.
DELIVERY_RTOL = 1e-9


@dataclass(frozen=True)
class Actuators:
    """Per-channel limits of the horizontal actuation, body frame.

    Attributes
    ----------
    tau_x : float
        Largest surge force (N), > 0.
    tau_y : float
        Largest sway force (N), > 0.
    tau_psi : float
        Largest yaw moment (N m), > 0.
    source : str
        Where the limits come from (a vehicle preset name or ``"declared"``).
    thrusters : ThrusterAllocation or None
        The thrusters behind the limits, when known: then a force box must also be deliverable
        by them (the channel limits cannot all be reached at once).
    note : str
        What a user should know when the limits bind, in plain words (e.g. that a vehicle
        has no sway thruster); added to the reason.

    Raises
    ------
    ParameterError
        If a limit is not finite and positive.
    """

    tau_x: float
    tau_y: float
    tau_psi: float
    source: str = "declared"
    thrusters: ThrusterAllocation | None = None
    note: str = ""
    #: The ``[actuators] kind`` of these limits.
    kind: ClassVar[ActuationKind] = "fully-actuated"

    def __post_init__(self) -> None:
        for name in ("tau_x", "tau_y", "tau_psi"):
            value = require_finite(name, getattr(self, name))
            if value <= 0.0:
                raise ParameterError(f"actuator limit {name} must be > 0, got {value!r}")
            object.__setattr__(self, name, value)

    def limits(self) -> tuple[float, float, float]:
        """``(tau_x, tau_y, tau_psi)`` (N, N, N m)."""
        return (self.tau_x, self.tau_y, self.tau_psi)

    def ratios(self, peak: tuple[float, float, float]) -> tuple[float, float, float]:
        """``peak_k / limit_k`` per channel: above 1 the channel cannot deliver the peak.

        Parameters
        ----------
        peak : tuple of float
            Peak ``(|tau_x|, |tau_y|, |tau_psi|)`` (N, N, N m, body frame).
        """
        lim = self.limits()
        return (peak[0] / lim[0], peak[1] / lim[1], peak[2] / lim[2])

    def admits(self, peak: tuple[float, float, float]) -> bool:
        """Every force of the box ``|tau_k| <= peak_k`` can be delivered (exact: box corners, convexity).

        Parameters
        ----------
        peak : tuple of float
            Half-widths ``(|tau_x|, |tau_y|, |tau_psi|)`` of the box (N, N, N m, body frame).
        """
        if not all(r <= 1.0 for r in self.ratios(peak)):
            return False
        return self.thrusters is None or self.thrusters.contains_box(peak)

    def utilisation(self, peak: tuple[float, float, float]) -> float:
        """How much of the actuation the box ``|tau_k| <= peak_k`` uses: at most 1 when deliverable.

        The largest per-channel ratio, and with thrusters the inverse of the largest scale of the
        box the thrusters can deliver whole (exact, one LP).

        Parameters
        ----------
        peak : tuple of float
            Half-widths ``(|tau_x|, |tau_y|, |tau_psi|)`` of the box (N, N, N m, body frame).
        """
        worst = max(self.ratios(peak))
        if self.thrusters is not None and any(p > 0.0 for p in peak):
            scale = self.thrusters.largest_box_scale(peak)
            # a box so large that the LP's scale rounds to 0 (a review's 1e12 kg/s damping) uses it infinitely
            worst = max(worst, math.inf if scale <= 0.0 else 1.0 / scale)
        return float(worst)

    def binding(self, peak: tuple[float, float, float]) -> tuple[str, float]:
        """What binds the box ``|tau_k| <= peak_k``, and its ratio.

        The channel with the largest ``peak / limit``, or ``"thrusters"`` when the thruster
        polytope binds harder (:meth:`utilisation`).

        Parameters
        ----------
        peak : tuple of float
            Half-widths ``(|tau_x|, |tau_y|, |tau_psi|)`` of the box (N, N, N m, body frame).
        """
        r = self.ratios(peak)
        k = int(np.argmax(r))
        if self.thrusters is not None:
            used = self.utilisation(peak)
            if used > r[k]:
                return "thrusters", used
        return CHANNELS[k], float(r[k])

    def saturate(self, tau: FloatArray, surge: FloatArray | None = None) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Clip commanded forces ``tau (..., 3)`` to the limits; also the per-vehicle active flag.

        With thrusters the command is first saturated by the allocation, then clipped per channel.

        Parameters
        ----------
        tau : ndarray, shape (..., 3)
            Commanded ``[tau_x, tau_y, tau_psi]`` (N, N, N m, body frame).
        surge : ndarray, optional
            Surge speeds ``u`` (m/s), shape ``tau.shape[:-1]``: unused, thrusters do not depend on it.

        Returns
        -------
        applied : ndarray, shape (..., 3)
            The forces the actuators deliver (N, N, N m).
        active : ndarray of bool, shape (...)
            Some channel is at its limit.
        """
        lim = np.asarray(self.limits(), dtype=float)
        if self.thrusters is not None:
            tau, active = self.thrusters.saturate(tau)
            clipped = np.clip(tau, -lim, lim)
            return clipped, active | np.any(clipped != tau, axis=-1)
        clipped = np.clip(tau, -lim, lim)
        return clipped, np.any(clipped != tau, axis=-1)

    def to_dict(self) -> dict[str, Any]:
        """The ``limits`` object of the JSON reports: ``{force_x, force_y, moment}`` (N, N, N m)."""
        return dict(zip(CHANNELS, self.limits()))


@dataclass(frozen=True)
class RudderActuation:
    """A propeller and a tail rudder: the horizontal actuation of a torpedo AUV (no sway thruster).

    The body force at surge speed ``u`` (m/s), thrust ``T`` (N) and rudder angle ``delta`` (rad) is
    ``(T, Y_uu_delta u^2 delta, N_uu_delta u^2 delta)`` (N, N, N m): the sway force and the yaw
    moment come from one deflection and keep the ratio ``N_uu_delta / Y_uu_delta`` (m, the
    rudder's signed lever arm, negative behind the centre).

    Attributes
    ----------
    tau_x : float
        Largest propeller thrust ``|T|`` (N), > 0.
    rudder_max : float
        Largest rudder deflection ``|delta|`` (rad), in ``(0, MAX_RUDDER]``.
    rudder_sway : float
        ``Y_uu_delta``, sway force per ``u^2 delta`` (kg/(m rad)), nonzero.
    rudder_yaw : float
        ``N_uu_delta``, yaw moment per ``u^2 delta`` (kg/rad), nonzero.
    source : str
        Where the figures come from (a vehicle preset name or ``"declared"``).
    note : str
        What a user should know, in plain words; added to the actuator reason.

    Raises
    ------
    ParameterError
        If a figure is not finite, the thrust is not positive, the deflection is outside
        ``(0, MAX_RUDDER]`` or a rudder derivative is zero.
    """

    tau_x: float
    rudder_max: float
    rudder_sway: float
    rudder_yaw: float
    source: str = "declared"
    note: str = ""
    #: The ``[actuators] kind`` of this actuation.
    kind: ClassVar[ActuationKind] = "underactuated"

    def __post_init__(self) -> None:
        for name in ("tau_x", "rudder_max", "rudder_sway", "rudder_yaw"):
            object.__setattr__(self, name, require_finite(name, getattr(self, name)))
        if self.tau_x <= 0.0:
            raise ParameterError(f"actuators.tau_x (propeller thrust) must be > 0 N, got {self.tau_x!r}")
        if not 0.0 < self.rudder_max <= MAX_RUDDER:
            raise ParameterError(
                f"actuators.rudder_max must be in (0, {MAX_RUDDER:.4g}] rad (45 deg), got {self.rudder_max!r}: "
                "give the largest fin deflection in radians"
            )
        for name in ("rudder_sway", "rudder_yaw"):
            if getattr(self, name) == 0.0:
                raise ParameterError(f"actuators.{name} must be nonzero (kg/(m rad) or kg/rad), got 0")

    @property
    def lever_arm(self) -> float:
        """``N_uu_delta / Y_uu_delta`` (m): the rudder's signed x position (negative: behind the centre)."""
        return self.rudder_yaw / self.rudder_sway

    def authority(self, speed: float) -> tuple[float, float]:
        """The largest sway force (N) and yaw moment (N m) at surge speed ``speed``, both from full rudder.

        Parameters
        ----------
        speed : float
            Surge speed ``u`` (m/s).
        """
        q = speed * speed * self.rudder_max
        return abs(self.rudder_sway) * q, abs(self.rudder_yaw) * q

    def saturate(self, tau: FloatArray, surge: FloatArray | None = None) -> tuple[FloatArray, NDArray[np.bool_]]:
        """The forces delivered for commands ``tau (..., 3)`` at surge speeds ``surge``; also where they differ.

        The thrust is clipped to ``|T| <= tau_x``. The rudder answers the yaw command: ``delta =
        tau_psi / (N_uu_delta u^2)``, clipped to ``|delta| <= rudder_max`` (zero at ``u = 0``,
        where it has no authority), and the sway force is the one that deflection makes, not the
        commanded one.

        Parameters
        ----------
        tau : ndarray, shape (..., 3)
            Commanded ``[tau_x, tau_y, tau_psi]`` (N, N, N m, body frame).
        surge : ndarray
            Surge speeds ``u`` (m/s), shape ``tau.shape[:-1]``; required, the rudder's forces depend on it.

        Returns
        -------
        applied : ndarray, shape (..., 3)
            The delivered forces (N, N, N m).
        active : ndarray of bool, shape (...)
            The delivered force differs from the command by more than :data:`DELIVERY_RTOL` (a
            limit is reached, or a sway force was commanded that the rudder does not give).

        Raises
        ------
        ParameterError
            Without ``surge``.
        """
        if surge is None:
            raise ParameterError("a rudder's forces depend on the surge speed: pass surge (m/s)")
        t = np.asarray(tau, dtype=float)
        q = np.broadcast_to(np.asarray(surge, dtype=float) ** 2, t.shape[:-1])
        safe = np.where(q > 0.0, q, 1.0)
        delta = np.where(q > 0.0, t[..., 2] / (self.rudder_yaw * safe), 0.0)
        delta = np.clip(delta, -self.rudder_max, self.rudder_max)
        applied = np.stack(
            [np.clip(t[..., 0], -self.tau_x, self.tau_x), self.rudder_sway * q * delta, self.rudder_yaw * q * delta],
            axis=-1,
        )
        scale = 1.0 + np.abs(t)
        active = np.any(np.abs(applied - t) > DELIVERY_RTOL * scale, axis=-1)
        return applied, active

    def to_dict(self) -> dict[str, Any]:
        """The ``limits`` object of the JSON reports: ``{force_x, rudder}`` (N, rad)."""
        return {"force_x": self.tau_x, "rudder": self.rudder_max}

    def describe(self) -> dict[str, Any]:
        """The rudder's figures: ``rudder_sway`` (kg/(m rad)), ``rudder_yaw`` (kg/rad), ``lever_arm`` (m)."""
        return {"rudder_sway": self.rudder_sway, "rudder_yaw": self.rudder_yaw, "lever_arm": self.lever_arm}


#: Horizontal actuation of either kind.
Actuation = Actuators | RudderActuation


def actuator_shortfall(actuators: Actuators, peak: tuple[float, float, float]) -> str:
    """One readable sentence: which channel cannot deliver the certified peak, by how much.

    Parameters
    ----------
    actuators : Actuators
        The declared limits.
    peak : tuple of float
        Certified peak ``(|tau_x|, |tau_y|, |tau_psi|)`` (N, N, N m).
    """
    over = [(c, p, lim) for c, p, lim in zip(CHANNELS, peak, actuators.limits()) if p > lim]
    if not over and actuators.thrusters is not None and not actuators.thrusters.contains_box(peak):
        s = actuators.thrusters.largest_box_scale(peak)
        fx, fy, m = peak
        return (
            f"the thrusters cannot deliver the certified peaks together (|tau_x| <= {fx:.4g} N, |tau_y| <= {fy:.4g} N, "
            f"|tau_psi| <= {m:.4g} N m, each within its own limit): the largest scaled copy of that box of forces "
            f"they can deliver at every corner is {s:.3g} of it, {100.0 * (1.0 - s):.2g} % short"
        )
    if not over:
        return "every channel is within its limit"
    parts = [
        f"the {CHANNEL_WORDS[c]} needed reaches {p:.4g} {CHANNEL_UNITS[c]}, {p / lim:.3g}x the {lim:.4g} "
        f"{CHANNEL_UNITS[c]} the actuators give"
        for c, p, lim in sorted(over, key=lambda x: -x[1] / x[2])
    ]
    return "; ".join(parts)


#: Horizontal actuation of the vehicle presets; sources in ``docs/vehicles.md``.
#: ``remus100``: a propeller (67 N at its 1525 rpm limit at 1.5 m/s, Fossen's model after Allen
#: et al. 2000) and a tail rudder of +-13.6 deg with Prestero's (2001) fin derivatives
#: ``Y_uu_delta = 9.64 kg/(m rad)``, ``N_uu_delta = -6.15 kg/rad``: underactuated.
#: ``bluerov2-heavy``: four vectored T200 thrusters, about 86 N surge, 86 N sway and 23 N m yaw
#: one channel at a time, with von Benzon et al.'s (2022) thruster curve (30.6 N a thruster);
#: the allocation polytope is checked too, since the thrusters cannot give all three at once.
#: ``nps-auv2``: a propeller (192.1 N at its 1500 rpm limit, at every speed in Healey & Lienard's
#: model) and a rudder of +-20 deg with ``Y_uu_delta = 379.2 kg/(m rad)``,
#: ``N_uu_delta = -967.7 kg/rad`` (the model's ``Y_dr``, ``N_dr`` scaled by ``rho L^2/2``,
#: ``rho L^3/2``): underactuated.
VEHICLE_ACTUATORS: dict[str, Actuation] = {
    "remus100": RudderActuation(
        67.0,
        math.radians(13.6),
        9.64,
        -6.15,
        source="remus100",
        note="a REMUS 100 has a propeller and a rudder, no sway thruster",
    ),
    "bluerov2-heavy": Actuators(
        86.0, 86.0, 23.0, "bluerov2-heavy", bluerov2_heavy_thrusters(BENZON2022_THRUST, BENZON2022_THRUST)
    ),
    "nps-auv2": RudderActuation(
        192.1,
        math.radians(20.0),
        379.2,
        -967.7,
        source="nps-auv2",
        note="the NPS AUV II has a propeller and a rudder, no sway thruster",
    ),
}


def vehicle_actuators(name: str) -> Actuation:
    """The actuation of vehicle preset ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`VEHICLE_ACTUATORS` (``"remus100"``, ``"bluerov2-heavy"``, ``"nps-auv2"``).

    Raises
    ------
    ParameterError
        If the preset has no published actuation (e.g. ``paper2011``, a model from a paper).
    """
    try:
        return VEHICLE_ACTUATORS[name]
    except KeyError:
        raise ParameterError(
            f"vehicle preset {name!r} has no published actuator limits; known: {', '.join(VEHICLE_ACTUATORS)}"
        ) from None


def floor_peak(bound: tuple[float, float, float]) -> tuple[float, float, float]:
    """One certificate's thrust bound with each channel raised to :data:`~auv_hinf.numerics.integrators.FORCE_FLOOR`.

    Parameters
    ----------
    bound : tuple of float
        The thrust bound ``(|tau_x|, |tau_y|, |tau_psi|)`` (N, N, N m).
    """
    return (max(FORCE_FLOOR, bound[0]), max(FORCE_FLOOR, bound[1]), max(FORCE_FLOOR, bound[2]))


__all__ = [
    "ACTUATION_KINDS",
    "CHANNELS",
    "CHANNEL_UNITS",
    "CHANNEL_WORDS",
    "DELIVERY_RTOL",
    "LIMIT_UNITS",
    "MAX_RUDDER",
    "VEHICLE_ACTUATORS",
    "Actuation",
    "ActuationKind",
    "Actuators",
    "RudderActuation",
    "actuator_shortfall",
    "floor_peak",
    "vehicle_actuators",
]
