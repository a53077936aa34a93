"""Does each vehicle's own desired motion fit the envelope? Which vehicle and turn bind, what would fit?

At zero tracking error vehicle ``i``'s body velocities are its desired ones. In the inertial
frame (the paper) they are the centre path's for every vehicle: surge ``|q'|``, no sway, yaw
rate ``chi'``. In the path frame (:mod:`auv_hinf.mission.fleet`) they differ per vehicle:
surge ``|q'| - chi' d_y`` (in a turn of radius ``rho`` the outer vehicle goes
``s (1 + |d_y|/rho)``, the inner one ``s (1 - |d_y|/rho)``, which may stop or reverse), sway
``chi' d_x`` and yaw rate ``chi'``. :func:`reference_fit` checks every vehicle on its sound
tube (:func:`~auv_hinf.mission.tubes.path_frame_tube`) with the margins the certificate uses
(:func:`~auv_hinf.mission.margins.cell_margins`), so "inside" here is exactly the zero-error
condition of the closed-loop certificate. When some vehicle leaves, it names the vehicle,
the channel and the first turn where it leaves (sampled on the desired motion: a witness,
not part of the proof), and answers by bisection on the same test the smallest turn radius
and the largest formation scale that fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray, FormationFrame
from auv_hinf.mission.fleet import FleetReference, ReferenceTube, reference_from_dict, turn_radius, with_turn_radius
from auv_hinf.mission.margins import ErrorBounds, cell_margins
from auv_hinf.mission.paths import MissionReference
from auv_hinf.mission.tubes import PATH_FRAME_CELLS, path_frame_tube
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.bisection import largest_holding
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant

#: Relative width at which the bisections on the turn radius and on the offsets' scale stop (the
#: resolution of the start regions' bisections, far below any physical tolerance of a turn).
FIT_RTOL = 1e-5

#: Channel and edge of each margin (same order as :data:`~auv_hinf.mission.margins.MARGIN_NAMES`).
CHANNELS = (
    ("surge", "upper"),
    ("surge", "lower"),
    ("sway", "upper"),
    ("sway", "lower"),
    ("yaw_rate", "upper"),
    ("yaw_rate", "lower"),
)
#: A desired motion at most this far outside an edge (m/s, rad/s) is on it up to the tube's outward
#: rounding (:data:`~auv_hinf.mission.tubes.TUBE_RTOL` of the speeds, below 1e-7 in any valid envelope):
#: a refusal says it reaches the edge, not that it leaves it by a number of rounding's size.
EDGE_TOUCH = 1e-6
#: The ``[envelope]`` key of each channel.
ENVELOPE_KEYS = {"surge": "u", "sway": "v", "yaw_rate": "r"}
#: Samples of the desired motion over one period of the mission when locating the binding turn.
WITNESS_SAMPLES = 20_001
#: Span (s) searched for the binding turn when the mission has no period (a line).
WITNESS_SPAN = 1.0
#: Radius factor at which a turn counts as straight when checking that a straight path fits.
STRAIGHT_FACTOR = 1e9


@dataclass(frozen=True)
class Binding:
    """Where the desired motion first leaves the envelope.

    Attributes
    ----------
    vehicle : int
        Index of the vehicle (0-based, the order of the offsets).
    time : float or None
        Start of the first turn where it leaves (s): the first sample of the desired motion
        over one period that crosses the edge (``None`` when no sample crosses and only the
        sound tube does).
    channel : {"surge", "sway", "yaw_rate"}
    edge : {"upper", "lower"}
    margin : float
        The (negative) zero-error margin of that channel (m/s or rad/s).
    """

    vehicle: int
    time: float | None
    channel: str
    edge: str
    margin: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (``vehicle``, ``time``, ``channel``, ``edge``, ``margin``)."""
        return {
            "vehicle": self.vehicle,
            "time": self.time,
            "channel": self.channel,
            "edge": self.edge,
            "margin": self.margin,
        }


@dataclass(frozen=True)
class ReferenceFit:
    """Per-vehicle verdict on the desired motion at zero error.

    Attributes
    ----------
    frame : {"inertial", "path"}
    inside : tuple of bool
        Vehicle ``i``'s desired motion stays in the envelope for all time.
    margins : ndarray, shape (N, 6)
        Its smallest zero-error margins (:data:`~auv_hinf.mission.margins.MARGIN_NAMES`; m/s, rad/s).
    binding : Binding or None
        The worst vehicle and channel, when some vehicle leaves.
    turn_radius : float
        The mission's smallest radius of curvature (m; ``inf`` on a line).
    smallest_radius : float or None
        Smallest radius of curvature that fits every vehicle (m), when some vehicle leaves and
        the mission has a radius to change; ``None`` otherwise (also when not even a straight
        path fits).
    largest_offset : float or None
        In the path frame, when some vehicle leaves: the largest ``|d_i|`` (m) that fits with the
        shape scaled about the centre (``None`` if none fits).
    """

    frame: str
    inside: tuple[bool, ...]
    margins: FloatArray
    binding: Binding | None
    turn_radius: float
    smallest_radius: float | None
    largest_offset: float | None

    @property
    def ok(self) -> bool:
        """Every vehicle's desired motion fits."""
        return all(self.inside)

    def reason(self) -> str:
        """One line: which vehicle, channel and turn bind, and what would fit ('' when it fits)."""
        b = self.binding
        if b is None:
            return ""
        unit = "rad/s" if b.channel == "yaw_rate" else "m/s"
        who = (
            f"vehicle {b.vehicle + 1} (path frame)"
            if self.frame == "path"
            else "every vehicle (inertial frame: each moves as the centre path)"
        )
        channel = b.channel.replace("_", " ")
        if -b.margin <= EDGE_TOUCH:
            # on the edge to the tube's rounding: no room is left for the tracking errors, whose bounds the
            # certificate keeps inside the envelope with the desired motion
            key = ENVELOPE_KEYS[b.channel]
            head = (
                f"the desired motion of {who} reaches the envelope's {b.edge} {channel} edge (within "
                f"{-b.margin:.2g} {unit} of rounding), which leaves no room for the tracking errors: widen "
                f"[envelope] {key} past it or change the mission to stay inside it"
            )
        else:
            head = (
                f"the desired motion of {who} leaves the envelope's {b.edge} {channel} edge by {-b.margin:.4g} {unit}"
            )
        out = [
            head
            + ("" if b.time is None else f", first at t = {b.time:.4g} s")
            + ("" if math.isinf(self.turn_radius) else f" (turn radius {self.turn_radius:.4g} m)")
        ]
        if self.smallest_radius is not None:
            # rounded to the side that fits: a smallest radius of 20.00015 m printed "20 m" is the declared
            # radius that does not fit
            radius = significant(self.smallest_radius, ADVISED_DIGITS, up=True)
            out.append(f"smallest turn radius that fits: {radius:.4g} m")
        if self.largest_offset is not None:
            offset = significant(self.largest_offset, ADVISED_DIGITS, up=False)
            out.append(f"largest offset that fits (shape scaled): {offset:.4g} m")
        return "; ".join(out)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "frame": self.frame,
            "inside": list(self.inside),
            "binding": None if self.binding is None else self.binding.to_dict(),
            "turn_radius": None if math.isinf(self.turn_radius) else self.turn_radius,
            "smallest_turn_radius": self.smallest_radius,
            "largest_offset": self.largest_offset,
        }


def vehicle_margins(
    mission: MissionReference, offsets: FloatArray, frame: FormationFrame, envelope: Envelope
) -> FloatArray:
    """Smallest zero-error margins of each vehicle, shape ``(N, 6)`` (m/s, rad/s; see the module docstring).

    A vehicle whose along-track speed may reach zero gets its surge-lower margin no larger than
    that speed's lower bound (it would stop or reverse; the heading offset is then undefined).

    Parameters
    ----------
    mission : MissionReference
        Centre path.
    offsets : ndarray, shape (N, 2)
        Formation offsets (m), in ``frame``.
    frame : {"inertial", "path"}
        Frame of the offsets; in the inertial frame every vehicle moves as the centre.
    envelope : Envelope
        Operating envelope.
    """
    off = np.asarray(offsets, dtype=float)
    n = off.shape[0]
    own = off if frame == "path" else np.zeros((1, 2))  # inertial: every vehicle moves as the centre
    tube = path_frame_tube(mission, own)
    moving_cells = tube.speed[:, 0] > 0.0
    flat = np.full((moving_cells.size, 6), np.inf)
    if moving_cells.any():  # cells where a vehicle may stop have no heading offset: the surge bound below decides
        part = ReferenceTube(
            speed=tube.speed[moving_cells],
            offset=tube.offset[moving_cells],
            yaw_rate=tube.yaw_rate[moving_cells],
            accel=tube.accel[moving_cells],
            yaw_accel=tube.yaw_accel[moving_cells],
        )
        flat[moving_cells] = cell_margins(part, ErrorBounds(0.0, 0.0, 0.0, 0.0), envelope)
    out = flat.reshape(own.shape[0], PATH_FRAME_CELLS, 6).min(axis=1)
    b = mission.bounds()
    along = b.speed_min - np.maximum(own[:, 1] * b.turn_rate_min, own[:, 1] * b.turn_rate_max)
    out[:, 1] = np.where(along > 0.0, out[:, 1], np.minimum(out[:, 1], along))
    result: FloatArray = np.broadcast_to(out, (n, 6)).copy()
    return result


def _fits(mission: MissionReference, offsets: FloatArray, frame: FormationFrame, envelope: Envelope) -> bool:
    return bool(vehicle_margins(mission, offsets, frame, envelope).min() >= 0.0)


def _witness_time(fleet: FleetReference, vehicle: int, column: int, envelope: Envelope) -> float | None:
    """Time (s) of the worst sample of the first excursion of ``column`` beyond its edge, over one period."""
    span = float(getattr(fleet.mission, "period", WITNESS_SPAN))
    t = np.linspace(0.0, span, WITNESS_SAMPLES)
    m = fleet.motion(t)
    c, s = np.cos(m.psi[:, vehicle]), np.sin(m.psi[:, vehicle])
    v = m.v[:, vehicle]
    value = {"surge": c * v[:, 0] + s * v[:, 1], "sway": -s * v[:, 0] + c * v[:, 1], "yaw_rate": m.r[:, vehicle]}
    channel, edge = CHANNELS[column]
    lo, hi = {"surge": envelope.u, "sway": envelope.v, "yaw_rate": envelope.r}[channel]
    excess = value[channel] - hi if edge == "upper" else lo - value[channel]
    if channel == "surge" and edge == "lower":
        excess = np.maximum(excess, -value[channel])  # a stop counts even where the envelope allows reversing
    out = np.flatnonzero(excess > 0.0)
    if out.size == 0:
        return None
    first = out[0]
    back = np.flatnonzero(excess[first:] <= 0.0)
    last = first + (back[0] if back.size else excess.size - first)
    return float(t[first + int(np.argmax(excess[first:last]))])


def reference_fit(
    mission: MissionReference, offsets: FloatArray, frame: FormationFrame, envelope: Envelope
) -> ReferenceFit:
    """Per-vehicle zero-error verdict, binding vehicle and turn, smallest radius and largest offset that fit.

    Parameters
    ----------
    mission : MissionReference
        Centre path.
    offsets : ndarray, shape (N, 2)
        Formation offsets (m), in ``frame``.
    frame : {"inertial", "path"}
        Frame of the offsets; the largest offset is searched in the path frame only.
    envelope : Envelope
        Operating envelope.
    """
    off = np.asarray(offsets, dtype=float)
    margins = vehicle_margins(mission, off, frame, envelope)
    inside = tuple(bool(x) for x in margins.min(axis=1) >= 0.0)
    radius = turn_radius(mission)
    if all(inside):
        return ReferenceFit(frame, inside, margins, None, radius, None, None)
    vehicle, column = (int(x) for x in np.unravel_index(int(np.argmin(margins)), margins.shape))
    channel, edge = CHANNELS[column]
    when = _witness_time(FleetReference(mission, off, None, frame), vehicle, column, envelope)
    binding = Binding(vehicle, when, channel, edge, float(margins[vehicle, column]))
    smallest = None
    if math.isfinite(radius):

        def fits_radius(curvature: float) -> bool:
            return _fits(reference_from_dict(**with_turn_radius(mission, 1.0 / curvature)), off, frame, envelope)

        if fits_radius(1.0 / (STRAIGHT_FACTOR * radius)):
            curvature = largest_holding(fits_radius, 1.0 / radius, check_lo=False, rtol=FIT_RTOL)
            smallest = 1.0 / curvature if curvature > 0.0 else None
    largest = None
    if frame == "path" and _fits(mission, 0.0 * off, frame, envelope):
        scale = largest_holding(lambda k: _fits(mission, k * off, frame, envelope), 1.0, check_lo=False, rtol=FIT_RTOL)
        largest = scale * float(np.hypot(off[:, 0], off[:, 1]).max())
    return ReferenceFit(frame, inside, margins, binding, radius, smallest, largest)


__all__ = [
    "CHANNELS",
    "FIT_RTOL",
    "STRAIGHT_FACTOR",
    "WITNESS_SAMPLES",
    "WITNESS_SPAN",
    "Binding",
    "ReferenceFit",
    "reference_fit",
    "vehicle_margins",
]
