"""Built-in configurations: one registry from a name to a complete :class:`FormationConfig`.

Each preset carries its vehicle, shape, envelope, reference and initial states, so the
certificate, the simulation and ``auv-hinf init`` all read the same object.
:func:`annotated_toml` writes any configuration as a commented TOML file.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Literal, get_args, get_origin

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from auv_hinf.actuation.limits import RudderActuation, vehicle_actuators
from auv_hinf.config.schema import (
    REFERENCE_MODELS,
    ActuatorsTable,
    DesignTable,
    DisturbanceTable,
    EnvelopeTable,
    FormationTable,
    GuidanceTable,
    ImplementationTable,
    NoiseTable,
    PlantTable,
    SimulationTable,
    UncertaintyTable,
    VehicleTable,
)
from auv_hinf.config.settings import (
    DisturbanceConfig,
    FormationConfig,
    ReferenceConfig,
    SimulationConfig,
    UncertaintyConfig,
)
from auv_hinf.exceptions import ConfigError
from auv_hinf.guidance.law import GuidanceConfig
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.models.envelope import PAPER_ENVELOPE, Envelope
from auv_hinf.models.jacobi import JacobiTransform, offsets_from_shape, regular_polygon, shape_from_offsets
from auv_hinf.models.vehicle import bluerov2_heavy, paper2011, preset, remus100

#: Demo envelope of the paper presets (u, v in m/s, r in rad/s). The paper's envelope has
#: ``|v| <= 1 m/s``, but its Section V vehicles start with sway exactly 1 m/s, on the edge, so
#: no sound check can leave them a margin. Widening sway to 1.5 m/s changes nothing else:
#: lambda (set by the surge damping at 3.5 m/s), sigma (set by the u = 0 vertex) and every gain
#: are the same as with the paper's envelope.
DEMO_ENVELOPE: Envelope = Envelope(u=PAPER_ENVELOPE.u, v=(-1.5, 1.5), r=PAPER_ENVELOPE.r)
#: Envelope of ``paper-triangle``.
TRIANGLE_ENVELOPE: Envelope = DEMO_ENVELOPE
#: Envelope of ``paper-hexagon``.
HEXAGON_ENVELOPE: Envelope = DEMO_ENVELOPE
#: Circumradius of the hexagon of Fig. 3 (m): the paper gives no size, so it is chosen here.
HEXAGON_RADIUS = 15.0
#: Jacobi shape of the Section V triangle (paper convention, m).
TRIANGLE_SHAPE = ((0.0, 10.0), (20.0, 0.0))
#: Section V initial states: positions (m), u = v = 1 m/s, psi = 0.1, 0.4, 0.7 rad,
#: r1 = r2 = 0.1 rad/s (r3 is not given in the paper: 0).
PAPER_TRIANGLE_INITIAL = (
    (25.0, 5.0, 0.1, 1.0, 1.0, 0.1),
    (-5.0, 10.0, 0.4, 1.0, 1.0, 0.1),
    (10.0, 8.0, 0.7, 1.0, 1.0, 0.0),
)
#: ``[formation] min_separation`` of ``paper-triangle`` (m), below the 2 m default: from the paper's
#: Section V start the shaped reference takes vehicles 2 and 3 within 1.10 m of each other (certified
#: 1.100 m, simulated 1.103 m at t = 25 s), and the paper's vehicle model has no hull size to respect.
PAPER_TRIANGLE_SEPARATION = 1.0


def spread_start(
    shape: ArrayLike,
    transform: JacobiTransform,
    scale: float = 1.5,
    rotation: float = 0.3,
) -> tuple[tuple[float, ...], ...]:
    """Initial states on the desired shape scaled by ``scale`` and rotated by ``rotation`` rad.

    Heading 0, surge 1 m/s, sway and yaw rate 0: the start used where the paper gives none.

    Parameters
    ----------
    shape : array_like, shape (N-1, 2)
        Desired Jacobi shape vectors (m, inertial frame).
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    scale : float
        Factor on the offsets from the centre (dimensionless).
    rotation : float
        Counter-clockwise rotation of the offsets about the centre (rad).
    """
    off = offsets_from_shape(np.asarray(shape, dtype=float), transform)
    c, s = np.cos(rotation), np.sin(rotation)
    pos = scale * off @ np.array([[c, s], [-s, c]])
    return tuple((float(x), float(y), 0.0, 1.0, 0.0, 0.0) for x, y in pos)


def _paper_triangle() -> FormationConfig:
    return FormationConfig(
        name="paper-triangle",
        vehicle=paper2011(),
        n=3,
        jacobi="paper",
        shape=TRIANGLE_SHAPE,
        envelope=TRIANGLE_ENVELOPE,
        simulation=SimulationConfig(initial=PAPER_TRIANGLE_INITIAL),
        min_separation=PAPER_TRIANGLE_SEPARATION,
    )


def _paper_hexagon() -> FormationConfig:
    t = JacobiTransform(6, "paper")
    rho = shape_from_offsets(regular_polygon(6, HEXAGON_RADIUS), t)
    shape = tuple((float(a), float(b)) for a, b in rho)
    return FormationConfig(
        name="paper-hexagon",
        vehicle=paper2011(),
        n=6,
        jacobi="paper",
        shape=shape,
        envelope=HEXAGON_ENVELOPE,
        simulation=SimulationConfig(initial=spread_start(shape, t)),
    )


#: Envelope of ``remus-line`` (m/s, m/s, rad/s): chosen with the robust certificate so that a
#: 0.2 m/s current plus the certified velocity error still fits the sway range.
REMUS_ENVELOPE: Envelope = Envelope(u=(0.5, 2.5), v=(-0.3, 0.3), r=(-0.3, 0.3))
#: Declared box of ``remus-line``: masses +-10 %, every damping coefficient +-20 %.
REMUS_BOX: tuple[tuple[str, tuple[float, float]], ...] = tuple(
    [(k, (0.9, 1.1)) for k in ("m11", "m22", "m33")]
    + [(k, (0.8, 1.2)) for k in ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")]
)
#: Mission speed of ``remus-line`` (m/s), the REMUS-100's nominal cruise.
REMUS_SPEED = 1.5
#: The simulated current (m/s, inertial) and plant corner of ``remus-line``: the corner whose
#: Munk-moment residual makes the nominal heading gains unstable (docs/derivations/robust.md).
REMUS_CURRENT = (-0.1, 0.15)
REMUS_PLANT = (("m11", 0.9), ("m22", 1.1), ("m33", 0.9))


def _remus_line() -> FormationConfig:
    t = JacobiTransform(3, "paper")
    off = offsets_from_shape(np.asarray(TRIANGLE_SHAPE), t)
    cx, cy = REMUS_CURRENT
    # on the raw mission at t = 0 (the line starts at the origin, heading 0), with the body
    # velocity that gives the mission's ground velocity in the current
    initial = tuple((float(x), float(y), 0.0, REMUS_SPEED - cx, -cy, 0.0) for x, y in off)
    return FormationConfig(
        name="remus-line",
        vehicle=remus100(),
        n=3,
        jacobi="paper",
        shape=TRIANGLE_SHAPE,
        envelope=REMUS_ENVELOPE,
        robust=True,
        reference=ReferenceConfig("line", (("speed", REMUS_SPEED), ("heading", 0.0))),
        simulation=SimulationConfig(
            horizon=60.0, start="paper", initial=initial, current=REMUS_CURRENT, plant=REMUS_PLANT
        ),
        uncertainty=UncertaintyConfig(REMUS_BOX),
        disturbance=DisturbanceConfig(current_speed=0.2),
        actuators=vehicle_actuators("remus100"),
    )


#: BlueROV2 Heavy fleet: a line abreast 4 m apart (m), surveying at 0.4 m/s in a 0.1 m/s current.
BLUEROV_OFFSETS = ((0.0, -6.0), (0.0, -2.0), (0.0, 2.0), (0.0, 6.0))
BLUEROV_SPEED = 0.4  # m/s
BLUEROV_CURRENT = 0.1  # m/s
#: Declared box: masses within +-10 %, quadratic damping within +-20 % (the BlueROV2 has no
#: linear sway and yaw damping in its published model).
BLUEROV_BOX = (
    ("m11", (0.9, 1.1)),
    ("m22", (0.9, 1.1)),
    ("m33", (0.9, 1.1)),
    ("d11_lin", (0.8, 1.2)),
    ("d11_quad", (0.8, 1.2)),
    ("d22_quad", (0.8, 1.2)),
    ("d33_quad", (0.8, 1.2)),
)
BLUEROV_ENVELOPE = Envelope(u=(-0.5, 1.0), v=(-0.5, 0.5), r=(-0.5, 0.5))


def _paper_shape(offsets: ArrayLike) -> tuple[tuple[float, float], ...]:
    """The ``[formation] shape`` (paper Jacobi vectors, m) of the vehicle offsets ``offsets`` (m)."""
    pts = np.asarray(offsets, dtype=float)
    return tuple((float(a), float(b)) for a, b in shape_from_offsets(pts, JacobiTransform(len(pts), "paper")))


def _bluerov2_line() -> FormationConfig:
    initial = tuple((float(x), float(y), 0.0, BLUEROV_SPEED, 0.0, 0.0) for x, y in BLUEROV_OFFSETS)
    return FormationConfig(
        name="bluerov2-line",
        vehicle=bluerov2_heavy(),
        n=4,
        jacobi="paper",
        shape=_paper_shape(BLUEROV_OFFSETS),
        envelope=BLUEROV_ENVELOPE,
        robust=True,
        reference=ReferenceConfig("line", (("speed", BLUEROV_SPEED), ("heading", 0.0))),
        simulation=SimulationConfig(horizon=60.0, start="paper", initial=initial),
        uncertainty=UncertaintyConfig(BLUEROV_BOX),
        disturbance=DisturbanceConfig(current_speed=BLUEROV_CURRENT),
        actuators=vehicle_actuators("bluerov2-heavy"),
    )


#: ``bluerov2-deployed``: the control period (s) and the lumped delay (s) of a 10 Hz loop whose
#: navigation solution arrives one sample late (docs/vehicles.md, "The deployed BlueROV2 line").
DEPLOYED_SAMPLE_TIME, DEPLOYED_DELAY = 0.1, 0.1
#: Its measurement-error bounds (m, m/s, rad, rad/s): a USBL-aided position, DVL velocity, an
#: INS-grade heading and a gyro yaw rate (sources in docs/vehicles.md).
DEPLOYED_NOISE = MeasurementNoise(position=0.05, velocity=0.004, heading=0.004, yaw_rate=0.002)


def _bluerov2_deployed() -> FormationConfig:
    base = _bluerov2_line()
    return replace(
        base,
        name="bluerov2-deployed",
        synthesis="deployed",
        simulation=SimulationConfig(horizon=60.0),
        uncertainty=UncertaintyConfig(()),
        disturbance=DisturbanceConfig(),
        implementation=Implementation(DEPLOYED_SAMPLE_TIME, DEPLOYED_DELAY, noise=DEPLOYED_NOISE),
    )


#: ``bluerov2-survey``: four BlueROV2 Heavy in a 3 m square, in the path frame (m; x along the
#: track, y across it).
BLUEROV_SQUARE = ((1.5, 1.5), (1.5, -1.5), (-1.5, 1.5), (-1.5, -1.5))
#: Its lawn-mower: 0.2 m/s, 100 m legs, 30 m turns and the 120 m between legs two such turns
#: need. Narrower turns are refused at 10 Hz (the composed certificate's advice for 10 m turns at
#: 0.35 m/s is 80 m; docs/vehicles.md).
BLUEROV_SURVEY_PATH = (("speed", 0.2), ("leg_length", 100.0), ("spacing", 120.0), ("turn_radius", 30.0))
#: Simulated time of ``bluerov2-survey`` (s): the first leg, the first turn and part of the second leg.
BLUEROV_SURVEY_HORIZON = 900.0


def _bluerov2_survey() -> FormationConfig:
    deployed = _bluerov2_deployed()
    shape = _paper_shape(BLUEROV_SQUARE)
    return replace(
        deployed,
        name="bluerov2-survey",
        shape=shape,
        frame="path",
        min_separation=1.0,
        reference=ReferenceConfig("lawnmower", BLUEROV_SURVEY_PATH),
        simulation=SimulationConfig(horizon=BLUEROV_SURVEY_HORIZON),
    )


#: ``remus-survey``: five REMUS 100 in a V facing forward, in the path frame (m; x along the track,
#: y across it on the body y axis): the lead ahead, each arm 10 m across and 5 m back per vehicle.
SURVEY_V = ((0.0, 0.0), (-5.0, 10.0), (-5.0, -10.0), (-10.0, 20.0), (-10.0, -20.0))
#: Its lawn-mower: the REMUS 100 cruise speed (m/s), 400 m legs, 240 m between legs and 60 m turns.
#: The certificate's smallest turn radius for this V in ``REMUS_ENVELOPE`` is 30.06 m (the outer
#: vehicles' surge 1.5 (1 -+ 20/R) m/s and the lead's sideslip 1.5 x 6/R m/s bind); 60 m leaves the
#: margin the tracking errors need. The legs are 240 m apart because a 180-degree turn of this
#: pattern spans 3.97 turn radii (:class:`~auv_hinf.mission.paths.LawnmowerReference`).
SURVEY_PATH = (("speed", REMUS_SPEED), ("leg_length", 400.0), ("spacing", 240.0), ("turn_radius", 60.0))
#: Simulated time of ``remus-survey`` (s): two legs, both 180-degree turns and the start of the third.
SURVEY_HORIZON = 1200.0


def _remus_survey() -> FormationConfig:
    t = JacobiTransform(5, "paper")
    shape = _paper_shape(SURVEY_V)
    # on the slots at t = 0: the pattern starts at the origin on a straight +x leg (course 0, no turn)
    off = offsets_from_shape(np.asarray(shape), t)
    initial = tuple((float(x), float(y), 0.0, REMUS_SPEED, 0.0, 0.0) for x, y in off)
    return FormationConfig(
        name="remus-survey",
        vehicle=remus100(),
        n=5,
        jacobi="paper",
        shape=shape,
        envelope=REMUS_ENVELOPE,
        frame="path",
        reference=ReferenceConfig("lawnmower", SURVEY_PATH),
        simulation=SimulationConfig(horizon=SURVEY_HORIZON, initial=initial),
        actuators=vehicle_actuators("remus100"),
    )


#: Cross current of ``remus-survey-ilos`` (m/s, inertial): across the first leg, 0.2 m/s, the
#: current a 1.5 m/s REMUS survey is planned to hold its lines in (docs/vehicles.md).
SURVEY_CURRENT = (0.0, 0.2)


def _remus_survey_ilos() -> FormationConfig:
    """``remus-survey`` steered as the REMUS really is: ILOS on each slot, propeller and rudder only.

    It declares the ``remus-line`` box and a current up to 0.2 m/s, which ``campaign`` samples.
    """
    base = _remus_survey()
    return replace(
        base,
        name="remus-survey-ilos",
        simulation=SimulationConfig(horizon=SURVEY_HORIZON, current=SURVEY_CURRENT),
        uncertainty=UncertaintyConfig(REMUS_BOX),
        disturbance=DisturbanceConfig(current_speed=float(np.hypot(*SURVEY_CURRENT))),
        guidance=GuidanceConfig(kind="ilos"),
    )


#: ``remus-transit-ilos``: three REMUS 100 in line abreast 15 m apart (m, inertial frame), on a
#: straight transit at the cruise speed.
TRANSIT_OFFSETS = ((0.0, 15.0), (0.0, 0.0), (0.0, -15.0))
#: Its declared box: masses +-3 % (a well-identified vehicle: the whole box certifies at once, in a
#: few seconds; masses +-10 % certify too in a 0.1 m/s current, by 57 cells of the box in about a
#: minute, docs/derivations/guidance.md), every damping coefficient +-20 %.
TRANSIT_BOX: tuple[tuple[str, tuple[float, float]], ...] = tuple(
    [(k, (0.97, 1.03)) for k in ("m11", "m22", "m33")]
    + [(k, (0.8, 1.2)) for k in ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")]
)
#: Its current bound (m/s) and the simulated current (m/s, inertial: across the track): a
#: sheltered transit, within what the cascade's certificate covers for this box.
TRANSIT_CURRENT = 0.1
#: Its ILOS gains: a heading loop of 2.4 rad/s and a 16 m lookahead, the gentlest candidates with
#: which the cascade's certificate covers the box and the current (docs/derivations/guidance.md).
TRANSIT_GUIDANCE = GuidanceConfig(kind="ilos", heading_bandwidth=2.4, lookahead=16.0)


def _remus_transit_ilos() -> FormationConfig:
    """Three REMUS 100 on a straight transit, steered by ILOS: a torpedo fleet the cascade's certificate covers."""
    return FormationConfig(
        name="remus-transit-ilos",
        vehicle=remus100(),
        n=3,
        jacobi="paper",
        shape=_paper_shape(TRANSIT_OFFSETS),
        envelope=REMUS_ENVELOPE,
        reference=ReferenceConfig("line", (("speed", REMUS_SPEED), ("heading", 0.0))),
        simulation=SimulationConfig(horizon=300.0, current=(0.0, TRANSIT_CURRENT)),
        uncertainty=UncertaintyConfig(TRANSIT_BOX),
        disturbance=DisturbanceConfig(current_speed=TRANSIT_CURRENT),
        actuators=vehicle_actuators("remus100"),
        guidance=TRANSIT_GUIDANCE,
    )


#: The registry: preset name -> factory of the complete configuration.
PRESET_REGISTRY: dict[str, Callable[[], FormationConfig]] = {
    "paper-triangle": _paper_triangle,
    "paper-hexagon": _paper_hexagon,
    "remus-line": _remus_line,
    "bluerov2-line": _bluerov2_line,
    "bluerov2-deployed": _bluerov2_deployed,
    "bluerov2-survey": _bluerov2_survey,
    "remus-survey": _remus_survey,
    "remus-survey-ilos": _remus_survey_ilos,
    "remus-transit-ilos": _remus_transit_ilos,
}
#: Names of the built-in presets (the CLI's ``--preset`` choices).
PRESETS: tuple[str, ...] = tuple(PRESET_REGISTRY)


def preset_config(name: str) -> FormationConfig:
    """The built-in configuration ``name`` (one of :data:`PRESETS`).

    Parameters
    ----------
    name : str
        The preset's name.

    Raises
    ------
    ConfigError
        For an unknown name; the message lists the valid ones.
    """
    make = PRESET_REGISTRY.get(name) if isinstance(name, str) else None
    if make is None:
        raise ConfigError(f"unknown preset {name!r}; expected one of: {', '.join(PRESETS)}")
    return make()


def toml_literal(value: Any) -> str:
    """A TOML literal for a bool, number, string or (nested) list.

    Parameters
    ----------
    value : Any
        The value.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    return "[" + ", ".join(toml_literal(v) for v in value) + "]"


def _range(info: FieldInfo) -> str:
    ops = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}
    parts = [f"{ops[k]} {getattr(m, k):g}" for m in info.metadata for k in ops if hasattr(m, k)]
    return f"; {', '.join(parts)}" if parts else ""


def _choices(info: FieldInfo) -> str:
    args = [a for u in get_args(info.annotation) or (info.annotation,) for a in get_args(u) or (u,)]
    if get_origin(info.annotation) is Literal:
        args = list(get_args(info.annotation))
    names = [a for a in args if isinstance(a, str)]
    return f"; one of: {', '.join(names)}" if names else ""


def _table(title: str, model: type[BaseModel], values: dict[str, Any], examples: dict[str, Any]) -> list[str]:
    doc = (model.__doc__ or "").strip().splitlines()[0].replace("``", "").split("]: ", 1)[-1]
    lines = ["", f"# {doc}", f"[{title}]"]
    for key, info in sorted(model.model_fields.items(), key=lambda kv: kv[0] != "kind"):
        name = info.alias or key
        if info.default_factory is not None:  # a sub-table, written on its own
            continue
        choices = _choices(info) if name != "kind" else ""
        lines.append(f"# {info.description or name}{_range(info)}{choices}")
        if name in values:
            lines.append(f"{name} = {toml_literal(values[name])}")
        else:
            ex = examples.get(name, info.examples[0] if info.examples else info.default)
            if ex is not None and not callable(ex) and repr(ex) != "PydanticUndefined":
                lines.append(f"# {name} = {toml_literal(ex)}")
    return lines


def annotated_toml(cfg: FormationConfig) -> str:
    """``cfg`` as a TOML file with a comment (meaning, unit, range) above every key.

    Keys that are not set appear commented out with an example value; the text is read
    back by :func:`~auv_hinf.config.settings.load_config` into an equal configuration (up to the name).

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    """
    data = cfg.to_toml_dict()
    vehicle = data["vehicle"]
    speed = float(cfg.reference.kwargs()["speed"])
    preset_vehicle = preset(vehicle["preset"], speed).to_dict() if "preset" in vehicle else {}
    lines = [
        f"# auv-hinf configuration (written by `auv-hinf init` from {cfg.name!r}).",
        "# Every table is optional; units are in brackets. `auv-hinf schema` prints the full JSON Schema.",
        "# Unknown keys are errors. Numbers may be integers where a float is expected, never strings.",
        f"# name = {toml_literal(cfg.name)}  # default: the file name without .toml",
    ]
    lines += _table(
        "vehicle",
        VehicleTable,
        vehicle,
        {k: v for k, v in preset_vehicle.items() if k != "name"},
    )
    lines += _table("formation", FormationTable, data["formation"], {"polygon_radius": 15.0})
    lines += _table("envelope", EnvelopeTable, data["envelope"], {})
    lines += _table("design", DesignTable, data["design"], {"gamma": 0.5, "lambda": -2.1})
    lines += _table("reference", REFERENCE_MODELS[cfg.reference.kind], data["reference"], {})
    sim = data.get("simulation", {})
    lines += _table(
        "simulation",
        SimulationTable,
        {k: v for k, v in sim.items() if k != "plant"},
        {"blend_time": 60.0},
    )
    lines += _table(
        "simulation.plant",
        PlantTable,
        sim.get("plant", {}),
        {k: 1.1 for k in PlantTable.model_fields},
    )
    lines += _table(
        "uncertainty",
        UncertaintyTable,
        data.get("uncertainty", {}),
        {k: [0.9, 1.1] for k in UncertaintyTable.model_fields},
    )
    lines += _table(
        "disturbance",
        DisturbanceTable,
        data.get("disturbance", {}),
        {"current_speed": 0.1, "current_rate": 0.0},
    )
    impl = data.get("implementation", {})
    lines += _table(
        "implementation",
        ImplementationTable,
        {k: v for k, v in impl.items() if k != "noise"},
        {"sample_time": 0.1, "delay": 0.1},
    )
    lines += _table(
        "implementation.noise",
        NoiseTable,
        impl.get("noise", {}),
        {"position": 0.1, "velocity": 0.02, "heading": 0.02, "yaw_rate": 0.01},
    )
    lines += _optional_table(
        "actuators", ActuatorsTable, data, _actuator_examples(cfg), "none declared: unlimited thrust"
    )
    lines += _optional_table(
        "guidance", GuidanceTable, data, {"kind": "ilos"}, "none declared: the fully actuated formation law"
    )
    return "\n".join(lines) + "\n"


def _actuator_examples(cfg: FormationConfig) -> dict[str, Any]:
    """The ``[actuators]`` example values: the declared actuation's own (a rudder's keys for a vehicle that
    has one, never a sway force for it), else a BlueROV2 Heavy's thruster set (N, N, N m)."""
    act = cfg.actuators
    if isinstance(act, RudderActuation):
        return {
            "kind": "underactuated",
            "tau_x": act.tau_x,
            "rudder_max": act.rudder_max,
            "rudder_sway": act.rudder_sway,
            "rudder_yaw": act.rudder_yaw,
            "tau_y": None,
            "tau_psi": None,
        }
    if act is not None:
        return {"tau_x": act.tau_x, "tau_y": act.tau_y, "tau_psi": act.tau_psi}
    return {"tau_x": 86.0, "tau_y": 86.0, "tau_psi": 23.0}


def _optional_table(
    name: str, model: type[BaseModel], data: dict[str, Any], examples: dict[str, Any], absent: str
) -> list[str]:
    """The lines of a table that may be left out; when ``data`` has none it stays a comment.

    An empty table would be an error (it declares the feature with its defaults), so an absent
    one is written with its header commented out too, saying what ``absent`` means.
    """
    lines = _table(name, model, data.get(name, {}), examples)
    if name in data:
        return lines
    # the note after a comment sign of its own: uncommenting the header leaves valid TOML
    return [line if not line.startswith("[") else f"# {line}  # {absent}" for line in lines]


__all__ = [
    "BLUEROV_BOX",
    "BLUEROV_CURRENT",
    "BLUEROV_ENVELOPE",
    "BLUEROV_OFFSETS",
    "BLUEROV_SPEED",
    "BLUEROV_SQUARE",
    "BLUEROV_SURVEY_HORIZON",
    "BLUEROV_SURVEY_PATH",
    "DEMO_ENVELOPE",
    "HEXAGON_ENVELOPE",
    "HEXAGON_RADIUS",
    "PAPER_TRIANGLE_INITIAL",
    "PAPER_TRIANGLE_SEPARATION",
    "PRESETS",
    "PRESET_REGISTRY",
    "REMUS_BOX",
    "REMUS_CURRENT",
    "REMUS_ENVELOPE",
    "REMUS_PLANT",
    "REMUS_SPEED",
    "SURVEY_HORIZON",
    "SURVEY_PATH",
    "SURVEY_V",
    "TRIANGLE_ENVELOPE",
    "TRIANGLE_SHAPE",
    "annotated_toml",
    "preset_config",
    "spread_start",
    "toml_literal",
]
