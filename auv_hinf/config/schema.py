"""The TOML configuration format as strict pydantic models: every table, its fields, units and defaults.

Every table is a model with ``extra="forbid"`` and strict types: a string is never read
as a number, a float never as an integer (an integer is fine where a float is expected),
NaN and infinities are refused. Each physical field carries its unit (``unit`` in the
JSON Schema) and its valid range. The tables are the vehicle, formation, envelope, design,
reference (one model per mission kind), simulation, and the conditions a design meets: the
true plant, the declared box and current, the actuators and the controller as it runs.
:func:`auv_hinf.config.messages.parse_config` turns a parsed TOML document into a validated
:class:`ConfigFile`; every problem becomes one line of a :class:`~auv_hinf.exceptions.ConfigError`
that names its TOML path (``design.gamma``) and, for a misspelled key, the closest valid name.
The default of every key is declared here once (:func:`schema_default`).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from typing import Annotated, Any, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from auv_hinf._typing import FormationFrame, GainMethod, JacobiKind, NoisePatternSetting, SynthesisKind
from auv_hinf.actuation.limits import MAX_RUDDER, ActuationKind
from auv_hinf.guidance import law as guidance_law
from auv_hinf.implementation.model import MIN_SAMPLE_TIME
from auv_hinf.law.gains import DEFAULT_K1
from auv_hinf.mission.paths import lawnmower_min_spacing
from auv_hinf.models.envelope import PAPER_ENVELOPE, check_interval
from auv_hinf.models.jacobi import (
    JacobiTransform,
    closest_pair,
    offsets_from_shape,
    regular_polygon,
    shape_from_offsets,
)
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.digits import significant

#: The nine model parameters: name -> (unit, lower-bound kind). Masses are > 0, damping >= 0.
PARAMETERS: dict[str, tuple[str, str]] = {
    "m11": ("kg", "gt"),
    "m22": ("kg", "gt"),
    "m33": ("kg m^2", "gt"),
    "d11_lin": ("kg/s", "ge"),
    "d11_quad": ("kg/m", "ge"),
    "d22_lin": ("kg/s", "ge"),
    "d22_quad": ("kg/m", "ge"),
    "d33_lin": ("kg m^2/s", "ge"),
    "d33_quad": ("kg m^2", "ge"),
}


VehiclePreset = Literal["paper2011", "remus100", "bluerov2-heavy", "nps-auv2"]


ActuatorPreset = Literal["remus100", "bluerov2-heavy", "nps-auv2"]


ReferenceKind = Literal["sine", "line", "circle", "lawnmower"]


StartKind = Literal["shaped", "paper"]


DEFAULT_POLYGON_RADIUS = 15.0  # m


DEFAULT_HEADING_POLES = (-1.0, -1.5)  # 1/s


#: Largest fleet accepted: certification is O(N) time and memory (about 0.5 s per 1000
#: vehicles); beyond this the configuration is refused with a ConfigError.
MAX_VEHICLES = 100_000


MAX_HORIZON = 1e5  # s
#: Shortest reference blending time (s): the finest sample time an implementation may declare; a
#: shorter blend asks for accelerations and jerks the shaped start's closed forms overflow on.
MIN_BLEND_TIME = 1e-3


MAX_COORDINATE = 1e6  # m: offsets, radii and path lengths beyond 1000 km are refused


#: Range of a vehicle's inertias (kg, kg m^2) and largest damping coefficient (kg/s, kg/m, kg m^2/s,
#: kg m^2): a laboratory model's 1e-6 to beyond the largest ships (5e8 kg). Outside it the numbers
#: over- or underflow in the certificates (1e300 kg divides to zero), and no vehicle is there.
MASS_RANGE = (1e-6, 1e9)
MAX_DAMPING = 1e12


#: Range of a ``[simulation.plant]`` multiplier and of an ``[uncertainty]`` box's ends: a plant ten
#: times off its model is not a model error but another vehicle (and with every coefficient at 1e-3
#: the run is so stiff that the integrator grinds for minutes).
MULTIPLIER_RANGE = (0.1, 10.0)


#: Largest magnitude of a design rate or gain (1/s, 1/s^2) and range of the H-infinity bound (s):
#: beyond them the Riccati and norm computations overflow (a million 1/s is a microsecond loop).
MAX_DESIGN_RATE = 1e6
GAMMA_RANGE = (1e-6, 1e6)


#: Largest angle (rad) taken as radians: one full turn. Every heading can be written within one turn, so a
#: heading, a bound of the heading range or a start heading beyond it is degrees typed by mistake (90 is a
#: quarter turn in degrees and 14 turns in radians). An error, not a warning: read as radians it silently
#: certifies and simulates another mission or another start.
MAX_ANGLE = 2.0 * math.pi


#: Largest yaw rate or angular frequency (rad/s) taken as rad/s: 2 rad/s is 115 deg/s. The presets' envelopes
#: allow at most 0.5 rad/s and their missions turn at most s / R (remus-survey: 1.5 m/s on 60 m turns,
#: 0.025 rad/s), while the yaw-rate bounds of these vehicles written in deg/s (5 to 30) are all above it. An
#: error: with the value read as rad/s the certificate fails with advice for another problem, or certifies an
#: envelope no run of these vehicles comes near.
MAX_RATE = 2.0


#: Largest speed (m/s) taken as m/s: 20 m/s (39 kn) is over five times the fastest preset envelope (the
#: paper's u <= 3.5 m/s; remus-line 2.5 m/s, bluerov2-line 1 m/s) and ten times the strongest ocean
#: currents, while a cruise speed written in cm/s (50 to 250) is far above it. An error, as for angles.
MAX_SPEED = 20.0
#: Smallest reference speed (m/s): 1 mm/s, a hundredth of the slowest survey in the presets (0.2 m/s)
#: and far below what a thruster holds against any current. The paths' time derivatives divide by
#: powers of the speed (a lawn-mower's turn jerk by its cube), so a speed that is practically zero
#: (1e-300) would overflow the mission's bounds; below this the mission is a station, not a path.
MIN_SPEED = 1e-3


#: A reference speed above this many times the envelope's fastest surge speed (m/s over m/s) cannot be
#: tracked inside the envelope (each vehicle's surge is about the path speed), so the certificate could only
#: fail, saying the mission does not fit; 2 flags a speed typed in km/h (3.6 times its value in m/s) or cm/s
#: (100 times) and leaves room for a mission that is merely a little too fast, which the certificate explains.
SPEED_FACTOR = 2.0


#: What a number too large for its unit probably is: unit -> (likely unit, factor to the expected unit).
_LIKELY_UNIT = {
    "rad": ("degrees", math.pi / 180.0),
    "rad/s": ("deg/s", math.pi / 180.0),
    "m/s": ("cm/s", 0.01),
}


#: Smallest magnitude a value must have for :func:`unit_slip` to name another unit: an angle of a degree
#: or two, a rate of a few deg/s or a speed of a few cm/s is not what a setting of these vehicles means.
MIN_SLIP = 2.0


def _numbers(value: float | Sequence[float], scale: float = 1.0) -> str:
    """``value`` (a number or a list) times ``scale``, with 4 significant digits."""
    if isinstance(value, (int, float)):
        return f"{value * scale:.4g}"
    return "[" + ", ".join(f"{v * scale:.4g}" for v in value) + "]"


def unit_slip(unit: str, value: float | Sequence[float]) -> str:
    """``": it looks like degrees; 90 degrees is 1.571 rad"``: the likely unit of a value too large for ``unit``.

    Parameters
    ----------
    unit : str
        The unit the key expects (``"rad"``, ``"rad/s"`` or ``"m/s"``; others give ``""``).
    value : float or sequence of float
        The value as written.
    """
    if unit not in _LIKELY_UNIT:
        return ""
    values = [value] if isinstance(value, (int, float)) else list(value)
    if max((abs(v) for v in values), default=0.0) < MIN_SLIP:  # 0.9 degrees is no likelier than 0.9 rad
        return ""
    likely, factor = _LIKELY_UNIT[unit]
    return f": it looks like {likely}; {_numbers(value)} {likely} is {_numbers(value, factor)} {unit}"


def _in_range(value: Sequence[float], unit: str, limit: float, what: str) -> None:
    """Raise ``ValueError`` naming the likely unit when some ``|value|`` exceeds ``limit`` (in ``unit``)."""
    if any(abs(v) > limit for v in value):
        raise ValueError(f"{_numbers(value)} {unit} is {what}{unit_slip(unit, value)}")


_ANGLE_TEXT = f"more than a full turn (|angle| > 2 pi = {MAX_ANGLE:.4g} rad)"


_RATE_TEXT = f"faster than these vehicles turn (|rate| > {MAX_RATE:g} rad/s = {math.degrees(MAX_RATE):.0f} deg/s)"


_SPEED_TEXT = f"faster than these vehicles go (|speed| > {MAX_SPEED:g} m/s)"


_DISTANCE_TEXT = f"farther than any formation spans (|coordinate| > {MAX_COORDINATE:g} m)"


def speed_misfit(speed: float, u: Sequence[float]) -> str | None:
    """Why a reference ``speed`` cannot be meant for the surge range ``u``, or ``None`` when it can.

    The speed is refused above :data:`SPEED_FACTOR` times the envelope's fastest surge; the message
    names the unit that would bring it inside.

    Parameters
    ----------
    speed : float
        ``reference.speed`` (m/s).
    u : sequence of 2 float
        ``envelope.u``, the surge range ``[min, max]`` (m/s).
    """
    top = max(abs(u[0]), abs(u[1]))
    if speed <= SPEED_FACTOR * top:
        return None
    hint = ": lower the speed or widen envelope.u"
    for name, factor in (("km/h", 1.0 / 3.6), ("cm/s", 0.01)):
        if speed * factor <= top:
            hint = f": it looks like {name}; {speed:g} {name} is {speed * factor:.4g} m/s"
            break
    times = f"{speed / top:.3g} times" if top > 0 else "above"
    return (
        f"reference.speed = {speed:g} m/s is {times} the fastest surge speed of envelope.u ({top:g} m/s), so "
        f"no run at this speed stays in the envelope{hint}"
    )


def _field(default: Any, description: str, unit: str = "", **kw: Any) -> Any:
    """A pydantic ``Field`` whose description ends with the unit, which is also kept in the schema."""
    text = f"{description} [{unit}]" if unit else description
    return Field(
        default,
        description=text,
        json_schema_extra={"unit": unit} if unit else None,
        **kw,
    )


def _multiplier(name: str) -> Any:
    """The field of the simulated plant's multiplier of coefficient ``name`` (within :data:`MULTIPLIER_RANGE`)."""
    return _field(None, f"multiplier of {name}", ge=MULTIPLIER_RANGE[0], le=MULTIPLIER_RANGE[1])


Pair = Annotated[list[float], Field(min_length=2, max_length=2)]


Point = Annotated[
    list[Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]],
    Field(min_length=2, max_length=2),
]


NegativePair = Annotated[list[Annotated[float, Field(lt=0.0)]], Field(min_length=2, max_length=2)]


StateRow = Annotated[list[float], Field(min_length=6, max_length=6)]


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


_KIND_TEXT = "path kind: sine, line, circle or lawnmower, each with its own keys (see `auv-hinf schema`)"


class _Reference(_Table):
    speed: float = _field(1.0, "speed of the formation centre along the path", "m/s", ge=MIN_SPEED, le=MAX_SPEED)


class SineReference(_Reference):
    """Sine path ``[speed t, amplitude sin(omega t)]`` (the paper's Section V)."""

    kind: Literal["sine"] = _field("sine", _KIND_TEXT)
    amplitude: float = _field(30.0, "amplitude of the lateral sine", "m", ge=0.0, le=MAX_COORDINATE)
    omega: float = _field(0.1, "angular frequency of the sine", "rad/s", gt=0.0, le=MAX_RATE)


class LineReference(_Reference):
    """Straight line at constant heading."""

    kind: Literal["line"] = _field("line", _KIND_TEXT)
    heading: float = _field(0.0, "direction of travel from the x axis", "rad", ge=-MAX_ANGLE, le=MAX_ANGLE)


class CircleReference(_Reference):
    """Circle of given radius."""

    kind: Literal["circle"] = _field("circle", _KIND_TEXT)
    radius: float = _field(..., "circle radius", "m", gt=0.0, le=MAX_COORDINATE, examples=[50.0])


class LawnmowerReference(_Reference):
    """Survey pattern: straight legs joined by turns."""

    kind: Literal["lawnmower"] = _field("lawnmower", _KIND_TEXT)
    leg_length: float = _field(..., "length of one straight leg", "m", gt=0.0, le=MAX_COORDINATE, examples=[200.0])
    spacing: float = _field(
        ...,
        "distance between neighbouring legs; at least about 3.97 turn_radius (two turns fit)",
        "m",
        gt=0.0,
        le=MAX_COORDINATE,
        examples=[100.0],
    )
    turn_radius: float = _field(
        ...,
        "smallest radius of the turns; at most about spacing / 3.97",
        "m",
        gt=0.0,
        le=MAX_COORDINATE,
        examples=[20.0],
    )

    @model_validator(mode="after")
    def _turns_fit(self) -> LawnmowerReference:
        need = lawnmower_min_spacing(self.speed, self.turn_radius)
        if self.spacing < need:
            raise ValueError(
                # rounded outwards: the values written certainly pass
                f"spacing must be >= {significant(need, 6, up=True):g} m to hold two 90-degree turns of turn_radius "
                f"{self.turn_radius:g} m (2 D, about 3.97 turn_radius), got {self.spacing:g} m: widen spacing, or "
                f"lower turn_radius to at most {significant(self.spacing * self.turn_radius / need, 4, up=False):g} m"
            )
        return self


REFERENCE_MODELS: dict[str, type[_Reference]] = {
    "sine": SineReference,
    "line": LineReference,
    "circle": CircleReference,
    "lawnmower": LawnmowerReference,
}


ReferenceTable = Annotated[
    SineReference | LineReference | CircleReference | LawnmowerReference,
    Field(discriminator="kind"),
]


class PlantTable(_Table):
    """``[simulation.plant]``: the true plant as multipliers (0.1 to 10) of the controller's parameters."""

    m11: float | None = _multiplier("m11")
    m22: float | None = _multiplier("m22")
    m33: float | None = _multiplier("m33")
    d11_lin: float | None = _multiplier("d11_lin")
    d11_quad: float | None = _multiplier("d11_quad")
    d22_lin: float | None = _multiplier("d22_lin")
    d22_quad: float | None = _multiplier("d22_quad")
    d33_lin: float | None = _multiplier("d33_lin")
    d33_quad: float | None = _multiplier("d33_quad")


class UncertaintyTable(_Table):
    """``[uncertainty]``: declared box of relative multipliers ``[lo, hi]``, 0.1 <= lo <= 1 <= hi <= 10."""

    m11: Pair | None = _field(None, "relative range [lo, hi] of m11")
    m22: Pair | None = _field(None, "relative range [lo, hi] of m22")
    m33: Pair | None = _field(None, "relative range [lo, hi] of m33")
    d11_lin: Pair | None = _field(None, "relative range [lo, hi] of d11_lin")
    d11_quad: Pair | None = _field(None, "relative range [lo, hi] of d11_quad")
    d22_lin: Pair | None = _field(None, "relative range [lo, hi] of d22_lin")
    d22_quad: Pair | None = _field(None, "relative range [lo, hi] of d22_quad")
    d33_lin: Pair | None = _field(None, "relative range [lo, hi] of d33_lin")
    d33_quad: Pair | None = _field(None, "relative range [lo, hi] of d33_quad")

    @field_validator(*PARAMETERS)
    @classmethod
    def _box(cls, value: list[float] | None, info: Any) -> list[float] | None:
        lo, hi = MULTIPLIER_RANGE
        if value is not None and not (lo <= value[0] <= 1.0 <= value[1] <= hi):
            raise ValueError(f"a relative range [lo, hi] must satisfy {lo:g} <= lo <= 1 <= hi <= {hi:g}, got {value}")
        return value


class ActuatorsTable(_Table):
    """``[actuators]``: what the vehicle can push; the certificate checks the law's peak force against it."""

    preset: ActuatorPreset | None = _field(
        None,
        "published actuation of a vehicle preset: that [vehicle] preset's own, or borrowed by a custom vehicle "
        "(see docs/vehicles.md)",
    )
    kind: ActuationKind = _field(
        "fully-actuated",
        "fully-actuated: independent surge force, sway force and yaw moment (tau_x, tau_y, tau_psi); "
        "underactuated: a propeller (tau_x) and a rudder (rudder_max, rudder_sway, rudder_yaw), no sway thruster",
    )
    tau_x: float | None = _field(
        None, "largest surge force (the propeller's thrust when underactuated)", "N", gt=0.0, examples=[86.0]
    )
    tau_y: float | None = _field(None, "largest sway force (fully actuated only)", "N", gt=0.0, examples=[86.0])
    tau_psi: float | None = _field(None, "largest yaw moment (fully actuated only)", "N m", gt=0.0, examples=[23.0])
    rudder_max: float | None = _field(
        None,
        f"largest rudder deflection (underactuated only), at most {MAX_RUDDER:.4g} rad",
        "rad",
        gt=0.0,
        le=MAX_RUDDER,
        examples=[0.2374],
    )
    rudder_sway: float | None = _field(
        None, "Y_uu_delta: sway force per u^2 delta (underactuated only)", "kg/(m rad)", examples=[9.64]
    )
    rudder_yaw: float | None = _field(
        None, "N_uu_delta: yaw moment per u^2 delta (underactuated only)", "kg/rad", examples=[-6.15]
    )

    @model_validator(mode="after")
    def _one_source(self) -> ActuatorsTable:
        keys = ("tau_x", "tau_y", "tau_psi", *_RUDDER_KEYS)
        given = [k for k in keys if getattr(self, k) is not None]
        if self.preset is not None:
            if given or "kind" in self.model_fields_set:
                extra = given + (["kind"] if "kind" in self.model_fields_set else [])
                raise ValueError(f"give either preset or the limits, not both (got preset and {', '.join(extra)})")
            return self
        need = ("tau_x", "tau_y", "tau_psi") if self.kind == "fully-actuated" else ("tau_x", *_RUDDER_KEYS)
        other = [k for k in given if k not in need]
        if other:
            raise ValueError(
                f"{', '.join(other)} do not apply to kind = {self.kind!r}: give {', '.join(need)}"
                + (
                    " (a rudder gives its sway force with a yaw moment, never alone)"
                    if self.kind == "underactuated"
                    else ' (or kind = "underactuated" for a propeller and a rudder)'
                )
            )
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            units = "N, N, N m" if self.kind == "fully-actuated" else "N, rad, kg/(m rad), kg/rad"
            raise ValueError(f"give all of {', '.join(need)} ({units}) for kind = {self.kind!r}, or a preset")
        for k in _RUDDER_KEYS[1:]:
            if getattr(self, k) == 0.0:
                raise ValueError(f"{k} must be nonzero: a rudder with no {k[7:]} effect")
        return self


#: The keys of a rudder in ``[actuators]`` (underactuated kind).
_RUDDER_KEYS = ("rudder_max", "rudder_sway", "rudder_yaw")


class NoiseTable(_Table):
    """``[implementation.noise]``: bounds of the measurement errors (default: exact)."""

    position: float = _field(0.0, "bound of the horizontal position error (Euclidean)", "m", ge=0.0, le=MAX_COORDINATE)
    velocity: float = _field(0.0, "bound of the body-velocity error |(u, v)| (Euclidean)", "m/s", ge=0.0, le=MAX_SPEED)
    heading: float = _field(0.0, "bound of the heading error", "rad", ge=0.0, le=3.14159)
    yaw_rate: float = _field(0.0, "bound of the yaw-rate error", "rad/s", ge=0.0, le=MAX_RATE)


class ImplementationTable(_Table):
    """``[implementation]``: the controller as it runs (default: continuous, undelayed, exact)."""

    sample_time: float = _field(
        0.0,
        "control period, forces held between samples (0: continuous, and a [guidance] fleet's autopilot at "
        "10 Hz; else at least 0.001 s, 1 kHz)",
        "s",
        ge=0.0,
        le=60.0,
    )
    delay: float = _field(0.0, "lumped input + measurement delay", "s", ge=0.0, le=60.0)
    varying_delay: bool = _field(False, "false: every sample late by exactly delay; true: by any value in [0, delay]")
    noise: NoiseTable = Field(default_factory=NoiseTable, description="bounds of the measurement errors")

    @field_validator("sample_time")
    @classmethod
    def _period(cls, value: float) -> float:
        if 0.0 < value < MIN_SAMPLE_TIME:
            raise ValueError(
                f"sample_time = {value!r} s is below {MIN_SAMPLE_TIME} s (1 kHz), faster than any AUV's control "
                "loop: declare the real control period, or 0 for the continuous law"
            )
        return value


class GuidanceTable(_Table):
    """``[guidance]``: line-of-sight guidance and autopilots, for a vehicle with a propeller and a rudder."""

    kind: guidance_law.GuidanceKind = _field(
        "ilos", "los: plain line of sight; ilos: integral LOS, no cross-track offset in a constant current"
    )
    lookahead: float = _field(
        guidance_law.DEFAULT_LOOKAHEAD, "lookahead distance Delta", "m", gt=0.0, le=MAX_COORDINATE
    )
    integral_gain: float = _field(
        guidance_law.DEFAULT_INTEGRAL_GAIN,
        "ILOS integral gain sigma (the literature's stability conditions keep it below the speed less the "
        "current; the certificate judges the declared value)",
        "m/s",
        gt=0.0,
        le=MAX_SPEED,
    )
    heading_bandwidth: float = _field(
        guidance_law.DEFAULT_HEADING_BANDWIDTH, "natural frequency of the critically damped heading loop",
        "rad/s", gt=0.0, le=MAX_RATE * 10,
    )  # fmt: skip
    speed_gain: float = _field(
        guidance_law.DEFAULT_SPEED_GAIN, "gain of the along-track ground-speed loop", "1/s", gt=0.0, le=100.0
    )
    along_track_gain: float = _field(
        guidance_law.DEFAULT_ALONG_TRACK_GAIN, "gain of the along-track position correction", "1/s",
        ge=0.0, le=100.0,
    )  # fmt: skip
    along_track_length: float = _field(
        guidance_law.DEFAULT_ALONG_TRACK_LENGTH,
        "along-track error at which the speed correction saturates (to gain x length)", "m",
        gt=0.0, le=MAX_COORDINATE,
    )  # fmt: skip


class DisturbanceTable(_Table):
    """``[disturbance]``: declared bounds of the ocean current."""

    current_speed: float | None = _field(None, "bound on |current|", "m/s", ge=0.0, le=MAX_SPEED)
    current_rate: float | None = _field(None, "bound on |d current / dt|", "m/s^2", ge=0.0)


#: An action of the runtime monitor on a violated assumption (docs/deployment.md).
ActionName = Literal["warn", "hold", "stop"]


class DeployTable(_Table):
    """``[deploy]``: running the certified law on MAVLink vehicles with ``auv-hinf run`` (its options override these).

    See docs/deployment.md for the ArduSub settings the force mapping assumes.
    """

    connect: list[Annotated[str, Field(min_length=1)]] | None = _field(
        None,
        "one pymavlink connection string per vehicle, in the fleet's order (e.g. udpout:192.168.2.2:14550)",
        examples=[["udpout:192.168.2.2:14550"]],
    )
    pilot_gain: float = _field(
        1.0,
        "the vehicles' ArduSub pilot gain, which the force mapping assumes (checked against PilotGain)",
        ge=0.1,
        le=1.0,
    )
    voltage: float = _field(16.0, "thruster supply voltage, for the T200 thrust curve", "V", ge=12.0, le=20.0)
    telemetry_rate: float = _field(50.0, "navigation rate asked of every vehicle", "Hz", gt=0.0, le=50.0)
    command_latency: float = _field(
        0.0, "share of the [implementation] delay reserved for the command's way to the thrusters", "s", ge=0.0, le=60.0
    )
    on_violation: ActionName | None = _field(
        None,
        "action on every violated assumption (default: warn, and stop when a vehicle is missing, silent or "
        "in another mode than MANUAL)",
    )


def schema_default(table: type[BaseModel], key: str) -> Any:
    """The default of ``key`` in ``table`` as the schema declares it: the one source of every default.

    Lists come back as tuples (the frozen runtime objects hold tuples).

    Parameters
    ----------
    table : type of pydantic.BaseModel
        The table's model.
    key : str
        The field name (not its TOML alias).
    """
    default = table.model_fields[key].default
    return tuple(default) if isinstance(default, list) else default


class VehicleTable(_Table):
    """``[vehicle]``: a preset, or all nine parameters of the 3-DOF model.

    See :class:`~auv_hinf.models.vehicle.VehicleParams`.
    """

    preset: VehiclePreset | None = _field(
        None,
        "built-in vehicle; excludes the nine parameters (remus100 and nps-auv2 take their lift damping at the "
        "[reference] speed)",
    )
    name: str | None = _field(None, "label of a custom vehicle (default: the configuration name)", min_length=1)
    m11: float | None = _field(
        None, "surge inertia m - X_udot", "kg", ge=MASS_RANGE[0], le=MASS_RANGE[1], examples=[200.0]
    )
    m22: float | None = _field(
        None, "sway inertia m - Y_vdot", "kg", ge=MASS_RANGE[0], le=MASS_RANGE[1], examples=[250.0]
    )
    m33: float | None = _field(
        None, "yaw inertia I_z - N_rdot", "kg m^2", ge=MASS_RANGE[0], le=MASS_RANGE[1], examples=[80.0]
    )
    d11_lin: float | None = _field(None, "linear surge damping", "kg/s", ge=0.0, le=MAX_DAMPING, examples=[70.0])
    d11_quad: float | None = _field(
        None, "quadratic surge damping (times |u|)", "kg/m", ge=0.0, le=MAX_DAMPING, examples=[100.0]
    )
    d22_lin: float | None = _field(None, "linear sway damping", "kg/s", ge=0.0, le=MAX_DAMPING, examples=[100.0])
    d22_quad: float | None = _field(
        None, "quadratic sway damping (times |v|)", "kg/m", ge=0.0, le=MAX_DAMPING, examples=[200.0]
    )
    d33_lin: float | None = _field(None, "linear yaw damping", "kg m^2/s", ge=0.0, le=MAX_DAMPING, examples=[50.0])
    d33_quad: float | None = _field(
        None, "quadratic yaw damping (times |r|)", "kg m^2", ge=0.0, le=MAX_DAMPING, examples=[100.0]
    )

    @model_validator(mode="before")
    @classmethod
    def _preset_or_parameters(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        given = [k for k in PARAMETERS if k in data]
        if "preset" in data and given:
            raise ValueError(
                f"give either vehicle.preset or the nine parameters, not both "
                f"(got preset = {data['preset']!r} and {', '.join(given)})"
            )
        missing = [k for k in PARAMETERS if k not in data]
        if "preset" not in data and missing:
            hint = unknown_key_hints(data, list(cls.model_fields))
            raise ValueError(f"missing keys {missing} (or give vehicle.preset){hint}")
        return data

    def to_params(self, default_name: str, speed: float | None = None) -> VehicleParams:
        """The validated :class:`VehicleParams`.

        Parameters
        ----------
        default_name : str
            Name of a custom vehicle without ``name`` (a preset keeps its own).
        speed : float or None
            The mission's speed (m/s): a preset whose lift terms are linear damping at a design
            surge speed (``remus100``, ``nps-auv2``) is linearised there, not at its default 1.5 m/s.
        """
        if self.preset is not None:
            from auv_hinf.models.vehicle import preset

            return preset(self.preset, speed)
        values = {k: getattr(self, k) for k in PARAMETERS}
        return VehicleParams(**values, name=self.name or default_name)


def _check_distinct(offsets: Any) -> None:
    """Raise ``ValueError`` if two desired vehicle positions coincide (or are not finite)."""
    import numpy as np

    off = np.asarray(offsets, dtype=float)
    if not np.all(np.isfinite(off)):
        raise ValueError("desired vehicle positions must be finite")
    scale = max(1.0, float(np.max(np.abs(off))))
    a, b, dist = closest_pair(off / scale)  # O(N log N), k-d tree
    if dist <= 1e-9:
        raise ValueError(
            f"vehicles {a + 1} and {b + 1} have the same desired position "
            f"({off[a, 0]:.6g}, {off[a, 1]:.6g}) m; every vehicle needs its own place"
        )


class FormationTable(_Table):
    """``[formation]``: fleet size, Jacobi scaling, and at most one way of giving the shape."""

    n: int = _field(3, "number of vehicles", ge=2, le=MAX_VEHICLES)
    jacobi: JacobiKind = _field("paper", "Jacobi transform scaling (paper: as printed; orthonormal: unit rows)")
    frame: FormationFrame = _field(
        "inertial",
        "frame of the offsets: inertial (the paper: the shape is fixed in the earth frame) or path "
        "(offsets [along track, across track on the body y axis] turn with the path's course; every vehicle "
        "heads along the track)",
    )
    shape: list[Point] | None = _field(None, "N-1 desired Jacobi vectors [[x, y], ...]", "m")
    offsets: list[Point] | None = _field(None, "N desired vehicle offsets [[x, y], ...] from any common point", "m")
    polygon_radius: float | None = _field(
        None,
        "regular polygon of this circumradius (the default, with 15 m)",
        "m",
        gt=0.0,
        le=MAX_COORDINATE,
    )
    min_separation: float = _field(
        2.0,
        "smallest distance between any two vehicles the certificate must prove for the configured run "
        "(certified: the smallest slot distance less twice the certified position-error bound); the default "
        "exceeds a REMUS 100's hull length (1.6 m) and a BlueROV2 Heavy's width (0.58 m)",
        "m",
        gt=0.0,
        le=MAX_COORDINATE,
    )

    @model_validator(mode="after")
    def _one_shape(self) -> FormationTable:
        given = [k for k in ("shape", "offsets", "polygon_radius") if getattr(self, k) is not None]
        if len(given) > 1:
            raise ValueError(f"give exactly one of shape, offsets, polygon_radius (got {', '.join(given)})")
        for key, count in (("shape", self.n - 1), ("offsets", self.n)):
            rows = getattr(self, key)
            if rows is not None and len(rows) != count:
                raise ValueError(f"{key} must have {count} rows [x, y] for n = {self.n}, got {len(rows)}")
        _check_distinct(offsets_from_shape(self.jacobi_shape(), JacobiTransform(self.n, self.jacobi)))
        return self

    def jacobi_shape(self) -> tuple[tuple[float, float], ...]:
        """Desired Jacobi shape vectors (N-1 pairs, m) in this table's convention."""
        t = JacobiTransform(self.n, self.jacobi)
        if self.shape is not None:
            rho = self.shape
        elif self.offsets is not None:
            rho = shape_from_offsets(self.offsets, t).tolist()
        else:
            rho = shape_from_offsets(
                regular_polygon(self.n, self.polygon_radius or DEFAULT_POLYGON_RADIUS),
                t,
            ).tolist()
        return tuple((float(a), float(b)) for a, b in rho)


#: The unit, the largest magnitude and its words of each envelope range (see :data:`MAX_SPEED` and others).
_ENVELOPE_LIMITS = {
    "u": ("m/s", MAX_SPEED, _SPEED_TEXT),
    "v": ("m/s", MAX_SPEED, _SPEED_TEXT),
    "r": ("rad/s", MAX_RATE, _RATE_TEXT),
    "psi": ("rad", MAX_ANGLE, _ANGLE_TEXT),
}


#: The columns of a ``simulation.initial`` row, each with its range: column -> (name, unit, largest
#: magnitude, words).
_STATE_LIMITS = {
    0: ("x", "m", MAX_COORDINATE, _DISTANCE_TEXT),
    1: ("y", "m", MAX_COORDINATE, _DISTANCE_TEXT),
    2: ("psi", "rad", MAX_ANGLE, _ANGLE_TEXT),
    3: ("u", "m/s", MAX_SPEED, _SPEED_TEXT),
    4: ("v", "m/s", MAX_SPEED, _SPEED_TEXT),
    5: ("r", "rad/s", MAX_RATE, _RATE_TEXT),
}


class EnvelopeTable(_Table):
    """``[envelope]``: ranges [min, max] of the body velocities and heading."""

    u: Pair = _field(list(PAPER_ENVELOPE.u), f"surge speed range [min, max], |u| <= {MAX_SPEED:g}", "m/s")
    v: Pair = _field(list(PAPER_ENVELOPE.v), f"sway speed range [min, max], |v| <= {MAX_SPEED:g}", "m/s")
    r: Pair = _field(list(PAPER_ENVELOPE.r), f"yaw-rate range [min, max], |r| <= {MAX_RATE:g}", "rad/s")
    psi: Pair = _field(list(PAPER_ENVELOPE.psi), "heading range [min, max], at most 2 pi wide, |psi| <= 2 pi", "rad")

    @field_validator("u", "v", "r", "psi")
    @classmethod
    def _interval(cls, value: list[float], info: Any) -> list[float]:
        unit, limit, what = _ENVELOPE_LIMITS[info.field_name]
        _in_range(value, unit, limit, what)
        return list(check_interval(info.field_name, value))


class DesignTable(_Table):
    """``[design]``: Theorem 1 gain method and bounds, Theorem 2 and heading gains."""

    method: GainMethod = _field("stabilizing", "Theorem 1 gain: paper (eq. 32), stabilizing root, or minimal")
    gamma: float | None = _field(
        None, "H-infinity bound (default 1/sigma_upper of the envelope)", "s", ge=GAMMA_RANGE[0], le=GAMMA_RANGE[1]
    )
    lam: float | None = _field(
        None,
        "nominal lambda (default: the most negative over the envelope)",
        "1/s",
        lt=0.0,
        ge=-MAX_DESIGN_RATE,
        alias="lambda",
    )
    k1: float = _field(DEFAULT_K1, "Theorem 2 position gain", "1/s^2", gt=0.0, le=MAX_DESIGN_RATE)
    robust: bool = _field(
        False,
        "use the robust design: alpha, k1 and the heading gains chosen for the [uncertainty] box and "
        "[disturbance] current (certify, simulate and campaign all run these gains)",
    )
    synthesis: SynthesisKind = _field(
        "bandwidth",
        "how the robust design chooses its gains: bandwidth (one-parameter family, the baseline), lmi "
        "(LMI synthesis minimising the certified peak force for the box, the current and the actuators) or "
        "deployed (the gains whose composed certificate of the sampled, delayed, noisy loop gives the "
        "smallest position bound within the actuators; needs an [implementation] sample_time)",
    )
    heading_poles: NegativePair = _field(
        list(DEFAULT_HEADING_POLES),
        "two distinct negative closed-loop poles of the heading loop",
        "1/s",
    )
    integral: bool = _field(
        False,
        "integral action in the position loop (needs robust = true: the robust certificate covers it, "
        "with the integrator starting at zero)",
    )

    @field_validator("heading_poles")
    @classmethod
    def _distinct(cls, value: list[float]) -> list[float]:
        if value[0] == value[1]:
            raise ValueError(f"heading poles must be distinct (single-input pole placement), got {value}")
        return value

    @model_validator(mode="after")
    def _integral_is_robust(self) -> DesignTable:
        if self.integral and not self.robust:
            raise ValueError(
                "integral = true needs robust = true: integral action is designed and certified by the robust "
                "design (add an [uncertainty] box or a [disturbance] current, or leave them empty)"
            )
        if self.synthesis != "bandwidth" and not self.robust:
            # without robust the nominal Theorem 1 gains run, and the synthesis would be silently unused
            raise ValueError(
                f'synthesis = "{self.synthesis}" needs robust = true: the synthesis chooses the robust design\'s '
                "gains, and without it the nominal Theorem 1 gains run (the box and the current may be left empty)"
            )
        return self


class SimulationTable(_Table):
    """``[simulation]``: the closed-loop run."""

    horizon: float = _field(300.0, "simulated time", "s", gt=0.0, le=MAX_HORIZON)
    start: StartKind = _field(
        "shaped",
        "shaped: the reference blends from the actual start; paper: raw reference "
        "(certify judges the start in this mode, as simulate runs it)",
    )
    initial: list[StateRow] | None = _field(
        None,
        f"[x, y, psi, u, v, r] per vehicle (m, m, rad, m/s, m/s, rad/s; |psi| <= 2 pi, |u|, |v| <= {MAX_SPEED:g}, "
        f"|r| <= {MAX_RATE:g}); default: each on its slot, zero error",
    )
    current: Pair = _field([0.0, 0.0], f"constant ocean current, inertial frame, |current| <= {MAX_SPEED:g}", "m/s")
    blend_time: float | None = _field(
        None,
        "reference blending time (default: chosen by the certificate)",
        "s",
        ge=MIN_BLEND_TIME,
        le=MAX_HORIZON,
    )
    seed: int = _field(0, "seed of the noise and delay draws of a sampled implementation", ge=0)
    noise_pattern: NoisePatternSetting = _field(
        "uniform",
        "how a sampled run's measurement errors are drawn within the [implementation.noise] bounds: uniform "
        "(at random), or at the bound: bang-bang (the sign flipped every sample), bias (constant), slow (a "
        "square wave of 10 s period), against-error (opposing each measured error, so the law under-reacts); "
        "mixed: campaign run i takes the i-th of these five in turn (a single run: uniform)",
    )
    plant: PlantTable = Field(
        default_factory=PlantTable,
        description="true plant as multipliers of the parameters",
    )

    @field_validator("initial")
    @classmethod
    def _state_units(cls, rows: list[list[float]] | None) -> list[list[float]] | None:
        for k, row in enumerate(rows or []):
            for col, (name, unit, limit, what) in _STATE_LIMITS.items():
                if abs(row[col]) > limit:
                    raise ValueError(
                        f"row {k} (vehicle {k + 1}), {name} = {row[col]:g} {unit} is {what}{unit_slip(unit, row[col])}"
                    )
        return rows

    @field_validator("current")
    @classmethod
    def _current_speed(cls, value: list[float]) -> list[float]:
        if math.hypot(value[0], value[1]) > MAX_SPEED:
            raise ValueError(
                f"|{_numbers(value)}| m/s is stronger than any ocean current (|current| > {MAX_SPEED:g} m/s)"
                f"{unit_slip('m/s', value)}"
            )
        return value

    @model_validator(mode="before")
    @classmethod
    def _moved_thrust_limit(cls, data: Any) -> Any:
        if isinstance(data, dict) and "thrust_limit" in data:
            raise ValueError(
                "thrust_limit was replaced by the [actuators] table: write "
                '[actuators] tau_x = ..., tau_y = ..., tau_psi = ... (N, N, N m), or preset = "remus100" '
                "for a vehicle's published limits"
            )
        return data


#: Defaults that the runtime dataclasses, the design functions and the CLI read (each is the
#: default its table above declares: the schema is the one source).
DEFAULT_METHOD: GainMethod = schema_default(DesignTable, "method")


DEFAULT_FRAME: FormationFrame = schema_default(FormationTable, "frame")


DEFAULT_MIN_SEPARATION: float = schema_default(FormationTable, "min_separation")


DEFAULT_SYNTHESIS: SynthesisKind = schema_default(DesignTable, "synthesis")


DEFAULT_INTEGRAL: bool = schema_default(DesignTable, "integral")


DEFAULT_POLES: tuple[float, float] = schema_default(DesignTable, "heading_poles")


DEFAULT_HORIZON: float = schema_default(SimulationTable, "horizon")


DEFAULT_START: StartKind = schema_default(SimulationTable, "start")


DEFAULT_SEED: int = schema_default(SimulationTable, "seed")
DEFAULT_NOISE_PATTERN: NoisePatternSetting = schema_default(SimulationTable, "noise_pattern")


class ConfigFile(_Table):
    """A whole configuration file (every table optional)."""

    name: str | None = _field(None, "configuration name (default: the file stem)", min_length=1)
    vehicle: VehicleTable = Field(default_factory=lambda: VehicleTable(preset="paper2011"))
    formation: FormationTable = Field(default_factory=FormationTable)
    envelope: EnvelopeTable = Field(default_factory=EnvelopeTable)
    design: DesignTable = Field(default_factory=DesignTable)
    reference: ReferenceTable = Field(default_factory=SineReference)
    simulation: SimulationTable = Field(default_factory=SimulationTable)
    uncertainty: UncertaintyTable = Field(default_factory=UncertaintyTable)
    disturbance: DisturbanceTable = Field(default_factory=DisturbanceTable)
    actuators: ActuatorsTable | None = Field(
        default=None, description="actuator limits (default: none declared, unlimited thrust)"
    )
    implementation: ImplementationTable = Field(
        default_factory=ImplementationTable,
        description="the controller as it runs (default: continuous, undelayed, exact measurements)",
    )
    deploy: DeployTable = Field(
        default_factory=DeployTable, description="running the certified law on MAVLink vehicles (auv-hinf run)"
    )
    guidance: GuidanceTable | None = Field(
        default=None,
        description="line-of-sight guidance for a propeller-and-rudder vehicle (default: the fully actuated law)",
    )

    @model_validator(mode="before")
    @classmethod
    def _default_reference_kind(cls, data: Any) -> Any:
        ref = data.get("reference") if isinstance(data, dict) else None
        if isinstance(ref, dict) and "kind" not in ref:
            data = {**data, "reference": {"kind": "sine", **ref}}
        return data

    @model_validator(mode="after")
    def _initial_rows(self) -> ConfigFile:
        init = self.simulation.initial
        if init is not None and len(init) != self.formation.n:
            raise ValueError(f"simulation.initial must have one row per vehicle ({self.formation.n}), got {len(init)}")
        return self

    @model_validator(mode="after")
    def _actuators_of_the_vehicle(self) -> ConfigFile:
        # an actuator preset is one vehicle's published actuation: on another preset hull its
        # forces (or its rudder's coefficients, which scale with the hull) are another vehicle's
        # figures; a custom [vehicle] may borrow a preset's actuation (a perturbed REMUS, say)
        act, hull = self.actuators.preset if self.actuators is not None else None, self.vehicle.preset
        if act is not None and hull is not None and act != hull:
            has_own = hull in get_args(ActuatorPreset)
            own = f"give actuators.preset = {hull!r}, or" if has_own else "it has no published actuation: give"
            raise ValueError(
                f"actuators.preset = {act!r} is the {act} vehicle's own actuation, but vehicle.preset = {hull!r}: "
                f"{own} this vehicle's limits (tau_x, ... in N, N m and rad; docs/config.md)"
            )
        return self


def suggest_key(key: str, names: list[str]) -> str:
    """``; did you mean 'x'?`` for the closest of ``names``, else the list of valid names.

    Parameters
    ----------
    key : str
        The unknown key.
    names : list of str
        The valid keys.
    """
    close = difflib.get_close_matches(key, names, n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else f"; expected one of: {', '.join(names)}"


def table_keys(model: type[BaseModel]) -> list[str]:
    """The TOML keys of a table model (aliases such as ``lambda`` included).

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The table's model.
    """
    return [f.alias or name for name, f in model.model_fields.items()]


def unknown_key_hints(data: dict[str, Any], allowed: list[str]) -> str:
    """Text naming the keys of ``data`` that are not in ``allowed``, with a suggestion each.

    Parameters
    ----------
    data : dict
        The table as parsed.
    allowed : list of str
        Its valid keys.
    """
    return "".join(f"; unknown key {k!r}{suggest_key(str(k), allowed)}" for k in data if k not in allowed)


TABLES: dict[tuple[str, ...], type[BaseModel]] = {
    (): ConfigFile,
    ("vehicle",): VehicleTable,
    ("formation",): FormationTable,
    ("envelope",): EnvelopeTable,
    ("design",): DesignTable,
    ("simulation",): SimulationTable,
    ("simulation", "plant"): PlantTable,
    ("uncertainty",): UncertaintyTable,
    ("disturbance",): DisturbanceTable,
    ("actuators",): ActuatorsTable,
    ("implementation",): ImplementationTable,
    ("implementation", "noise"): NoiseTable,
    ("deploy",): DeployTable,
    ("guidance",): GuidanceTable,
    **{("reference", k): m for k, m in REFERENCE_MODELS.items()},
}


def key_unit(table: str, key: str) -> str:
    """The unit of ``[table] key`` as the schema declares it (``""``: dimensionless, or no such key).

    Parameters
    ----------
    table : str
        The TOML table, dotted when nested (``"implementation.noise"``); ``"reference"`` looks the
        key up in every reference kind's table.
    key : str
        The key, as the user writes it.
    """
    path = tuple(table.split("."))
    models = list(REFERENCE_MODELS.values()) if path == ("reference",) else [TABLES.get(path)]
    for model in models:
        if model is None:
            continue
        for name, f in model.model_fields.items():
            if key in (name, f.alias) and isinstance(f.json_schema_extra, dict):
                return str(f.json_schema_extra.get("unit", ""))
    return ""


def json_schema() -> dict[str, Any]:
    """JSON Schema of the TOML format (``auv-hinf schema``)."""
    schema = ConfigFile.model_json_schema(by_alias=True)
    schema["title"] = "auv-hinf configuration (TOML)"
    return schema


__all__ = [
    "DEFAULT_FRAME",
    "DEFAULT_HEADING_POLES",
    "DEFAULT_HORIZON",
    "DEFAULT_INTEGRAL",
    "DEFAULT_METHOD",
    "DEFAULT_MIN_SEPARATION",
    "DEFAULT_NOISE_PATTERN",
    "DEFAULT_POLES",
    "DEFAULT_POLYGON_RADIUS",
    "DEFAULT_SEED",
    "DEFAULT_START",
    "DEFAULT_SYNTHESIS",
    "MAX_ANGLE",
    "MAX_COORDINATE",
    "MAX_HORIZON",
    "MAX_RATE",
    "MAX_SPEED",
    "MAX_VEHICLES",
    "PARAMETERS",
    "REFERENCE_MODELS",
    "SPEED_FACTOR",
    "TABLES",
    "ActionName",
    "ActuatorPreset",
    "ActuatorsTable",
    "CircleReference",
    "ConfigFile",
    "DeployTable",
    "DesignTable",
    "DisturbanceTable",
    "EnvelopeTable",
    "FormationTable",
    "ImplementationTable",
    "LawnmowerReference",
    "LineReference",
    "NegativePair",
    "NoiseTable",
    "Pair",
    "PlantTable",
    "Point",
    "ReferenceKind",
    "ReferenceTable",
    "SimulationTable",
    "SineReference",
    "StartKind",
    "StateRow",
    "UncertaintyTable",
    "VehiclePreset",
    "VehicleTable",
    "json_schema",
    "key_unit",
    "schema_default",
    "speed_misfit",
    "suggest_key",
    "table_keys",
    "unit_slip",
    "unknown_key_hints",
]
