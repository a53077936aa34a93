"""What a vehicle can push: per-channel force limits in the body frame, and the saturation model.

:class:`Actuators` holds the largest body force ``|tau_x|`` (N), ``|tau_y|`` (N) and yaw
moment ``|tau_psi|`` (N m) the vehicle's propulsion gives, channel by channel. A certificate
bounds what the law commands over its whole certified set, as a box
``|tau_k| <= peak_k``; it is certified against the actuators only when that box lies inside
the feasible set (:meth:`Actuators.admits`). For per-channel limits the feasible set is itself
a box, so the test is exact channel by channel. With a thruster allocation
(:class:`~auv_hinf.actuation.thrusters.ThrusterAllocation`) the feasible set is a polytope and the
box is tested at its 8 corners, exact by convexity. The simulator applies
:meth:`Actuators.saturate` to the commanded forces; a certified run never reaches it.

The vehicle presets' limits, with their sources, are in :data:`VEHICLE_ACTUATORS` and
``docs/vehicles.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrusters import BENZON2022_THRUST, ThrusterAllocation, bluerov2_heavy_thrusters
from auv_hinf.exceptions import ParameterError, require_finite

#: Channel names in the order of ``tau = (tau_x, tau_y, tau_psi)``, as the JSON reports them.
CHANNELS = ("force_x", "force_y", "moment")
#: Words for the channels in reasons.
CHANNEL_WORDS = {"force_x": "surge force", "force_y": "sway force", "moment": "yaw moment"}
#: Units of the channels.
CHANNEL_UNITS = {"force_x": "N", "force_y": "N", "moment": "N m"}


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
            worst = max(worst, 1.0 / self.thrusters.largest_box_scale(peak))
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

    def saturate(self, tau: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Clip commanded forces ``tau (..., 3)`` to the limits; also the per-vehicle active flag.

        With thrusters the command is first saturated by the allocation, then clipped per channel.

        Parameters
        ----------
        tau : ndarray, shape (..., 3)
            Commanded ``[tau_x, tau_y, tau_psi]`` (N, N, N m, body frame).

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
        return (
            f"each channel is within its limit, but the thrusters cannot deliver the whole box of peak forces "
            f"at once (they reach {s:.3g} of it)"
        )
    if not over:
        return "every channel is within its limit"
    parts = [
        f"the {CHANNEL_WORDS[c]} needed reaches {p:.4g} {CHANNEL_UNITS[c]}, {p / lim:.3g}x the {lim:.4g} "
        f"{CHANNEL_UNITS[c]} the actuators give"
        for c, p, lim in sorted(over, key=lambda x: -x[1] / x[2])
    ]
    return "; ".join(parts)


#: Horizontal actuation of the vehicle presets (N, N, N m); sources in ``docs/vehicles.md``.
#: ``remus100``: about 67 N of propeller thrust at 1.5 m/s; no sway thruster, so its fins give
#: at most about 5.6 N of sway force, locked to a yaw moment of about 4.5 N m (the largest
#: values of the fin model; sway and yaw are coupled, so this box is optimistic).
#: ``bluerov2-heavy``: four vectored T200 thrusters, about 86 N surge, 86 N sway and 23 N m yaw
#: one channel at a time, with von Benzon et al.'s (2022) thruster curve (30.6 N a thruster);
#: the allocation polytope is checked too, since the thrusters cannot give all three at once.
VEHICLE_ACTUATORS: dict[str, Actuators] = {
    "remus100": Actuators(
        67.0,
        5.6,
        4.5,
        source="remus100",
        note="the fully actuated law needs a sway force that the REMUS 100's fins cannot give",
    ),
    "bluerov2-heavy": Actuators(
        86.0, 86.0, 23.0, "bluerov2-heavy", bluerov2_heavy_thrusters(BENZON2022_THRUST, BENZON2022_THRUST)
    ),
}


def vehicle_actuators(name: str) -> Actuators:
    """The actuator limits of vehicle preset ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`VEHICLE_ACTUATORS` (``"remus100"``, ``"bluerov2-heavy"``).

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


__all__ = [
    "CHANNELS",
    "CHANNEL_UNITS",
    "CHANNEL_WORDS",
    "VEHICLE_ACTUATORS",
    "Actuators",
    "actuator_shortfall",
    "vehicle_actuators",
]
