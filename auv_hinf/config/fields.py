"""Building blocks of the TOML schema: field helpers, the strict base table, the parameter list
and the ``[reference]`` models (one per mission kind). :mod:`auv_hinf.config.schema` assembles them."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

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
VehiclePreset = Literal["paper2011", "remus100", "bluerov2-heavy"]
ActuatorPreset = Literal["remus100", "bluerov2-heavy"]
SynthesisKind = Literal["bandwidth", "lmi"]
ReferenceKind = Literal["sine", "line", "circle", "lawnmower"]
StartKind = Literal["shaped", "paper"]
DEFAULT_POLYGON_RADIUS = 15.0  # m
DEFAULT_HEADING_POLES = (-1.0, -1.5)  # 1/s
#: Largest fleet accepted: certification is O(N) time and memory (about 0.5 s per 1000
#: vehicles); beyond this the configuration is refused with a ConfigError.
MAX_VEHICLES = 100_000
MAX_HORIZON = 1e5  # s
MAX_COORDINATE = 1e6  # m: offsets and radii beyond 1000 km are refused


def _field(default: Any, description: str, unit: str = "", **kw: Any) -> Any:
    """A pydantic ``Field`` whose description ends with the unit, which is also kept in the schema."""
    text = f"{description} [{unit}]" if unit else description
    return Field(
        default,
        description=text,
        json_schema_extra={"unit": unit} if unit else None,
        **kw,
    )


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
    speed: float = _field(1.0, "speed of the formation centre along the path", "m/s", gt=0.0)


class SineReference(_Reference):
    """Sine path ``[speed t, amplitude sin(omega t)]`` (the paper's Section V)."""

    kind: Literal["sine"] = _field("sine", _KIND_TEXT)
    amplitude: float = _field(30.0, "amplitude of the lateral sine", "m", ge=0.0)
    omega: float = _field(0.1, "angular frequency of the sine", "rad/s", gt=0.0)


class LineReference(_Reference):
    """Straight line at constant heading."""

    kind: Literal["line"] = _field("line", _KIND_TEXT)
    heading: float = _field(0.0, "direction of travel from the x axis", "rad")


class CircleReference(_Reference):
    """Circle of given radius."""

    kind: Literal["circle"] = _field("circle", _KIND_TEXT)
    radius: float = _field(..., "circle radius", "m", gt=0.0, examples=[50.0])


class LawnmowerReference(_Reference):
    """Survey pattern: straight legs joined by turns."""

    kind: Literal["lawnmower"] = _field("lawnmower", _KIND_TEXT)
    leg_length: float = _field(..., "length of one straight leg", "m", gt=0.0, examples=[200.0])
    spacing: float = _field(
        ...,
        "distance between neighbouring legs; at least about 3.97 turn_radius (two turns fit)",
        "m",
        gt=0.0,
        examples=[100.0],
    )
    turn_radius: float = _field(
        ..., "smallest radius of the turns; at most about spacing / 3.97", "m", gt=0.0, examples=[20.0]
    )


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
