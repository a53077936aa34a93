"""Strict configuration schema: types, ranges, unknown keys with hints, presets, round trips."""

from __future__ import annotations

import math
import typing
from dataclasses import replace

import numpy as np
import pytest
import tomllib
from pydantic import BaseModel

from auv_hinf.config.presets import PAPER_TRIANGLE_INITIAL, PRESETS, annotated_toml, preset_config, spread_start
from auv_hinf.config.schema import PARAMETERS, TABLES, ConfigFile, VehiclePreset, json_schema
from auv_hinf.config.settings import (
    DisturbanceConfig,
    FormationConfig,
    ReferenceConfig,
    SimulationConfig,
    UncertaintyConfig,
    config_from_dict,
    load_config,
    with_settings,
)
from auv_hinf.exceptions import ConfigError
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import PRESETS as VEHICLE_PRESETS
from auv_hinf.models.vehicle import paper2011

NINE = {"m11": 200, "m22": 250, "m33": 80, "d11_lin": 70, "d11_quad": 100, "d22_lin": 100, "d22_quad": 200,
        "d33_lin": 50, "d33_quad": 100}  # fmt: skip


def problems(data):
    with pytest.raises(ConfigError) as info:
        config_from_dict(data)
    return str(info.value).splitlines()


@pytest.mark.parametrize(
    "data, line",
    [
        ({"design": {"gama": 0.5}}, "design.gama is not a known key; did you mean 'gamma'?"),
        ({"design": {"methd": "paper"}}, "design.methd is not a known key; did you mean 'method'?"),
        ({"envelope": {"uu": [0, 1]}}, "envelope.uu is not a known key; did you mean 'u'?"),
        ({"reference": {"kind": "line", "headng": 1}}, "reference.headng is not a known key; did you mean 'heading'?"),
        ({"simulation": {"plant": {"m2": 1.1}}}, "simulation.plant.m2 is not a known key; did you mean 'm22'?"),
        ({"guidance": {"lookahed": 16.0}}, "guidance.lookahed is not a known key; did you mean 'lookahead'?"),
        ({"desgin": {}}, "[desgin] is an unknown table; did you mean 'design'?"),
        ({"name": ""}, "name must not be empty: leave it out for the default"),
        (
            {"vehicle": {"preset": "remus100", "name": ""}},
            "vehicle.name must not be empty: leave it out for the default",
        ),
        ({"gamma": 0.5}, "gamma is not a known top-level key; it belongs in [design]"),
    ],
)
def test_unknown_keys_rejected_with_hint(data, line):
    assert line in problems(data)


def test_every_table_of_the_format_names_its_own_unknown_keys():
    """A misspelt key in any table is reported in that table (not as an unknown top-level key)."""
    tables = [
        name
        for name, field in ConfigFile.model_fields.items()
        if any(
            isinstance(a, type) and issubclass(a, BaseModel)
            for a in (typing.get_args(field.annotation) or (field.annotation,))
        )
    ]
    assert "guidance" in tables and "implementation" in tables
    for name in tables:
        if name == "reference":  # a union by kind: its tables are keyed by the kind (the headng case above)
            continue
        lines = problems({name: {"zzz_not_a_key": 1.0}})
        assert (name,) in TABLES, name
        assert any(line.startswith(name) and "zzz_not_a_key" in line for line in lines), (name, lines)
        assert not any("top-level" in line for line in lines), (name, lines)


def test_whole_unknown_table_rejected():
    (line,) = problems({"controller": {"gain": 1.0}})
    assert line.startswith("[controller] is an unknown table; expected one of: ") and "design" in line


def test_string_number_rejected_int_accepted():
    assert problems({"vehicle": {**NINE, "m11": "200"}}) == [
        "vehicle.m11 has the wrong type: expected a number, got '200'"
    ]
    assert config_from_dict({"vehicle": NINE}).vehicle.m11 == 200.0
    assert problems({"formation": {"n": 3.0}}) == ["formation.n has the wrong type: expected an integer, got 3.0"]
    assert "design.k1 has the wrong type: expected a number, got True" in problems({"design": {"k1": True}})


def test_every_problem_listed_with_its_path_and_unit():
    lines = problems({"design": {"gamma": -1, "lambda": 0.5, "k1": math.nan}, "simulation": {"horizon": 0}})
    assert lines == [
        "design.gamma must be >= 1e-06 [s], got -1",
        "design.lambda must be < 0 [1/s], got 0.5",
        "design.k1 must be finite, got nan",
        "simulation.horizon must be > 0 [s], got 0",
    ]


def test_negative_mass_and_damping():
    lines = problems({"vehicle": {**NINE, "m33": -1.0, "d22_quad": -0.1}})
    assert lines == [
        "vehicle.m33 must be >= 1e-06 [kg m^2], got -1.0",
        "vehicle.d22_quad must be >= 0 [kg/m], got -0.1",
    ]


def test_preset_plus_parameters_rejected():
    (line,) = problems({"vehicle": {"preset": "remus100", "m11": 30.0}})
    assert "either vehicle.preset or the nine parameters, not both" in line and "m11" in line


def test_missing_vehicle_parameters_listed():
    (line,) = problems({"vehicle": {"m11": 1.0, "m2": 1.0}})
    assert "missing keys" in line and "'m22'" in line and "unknown key 'm2'; did you mean 'm22'?" in line


def test_envelope_psi_range_rejected_in_toml_and_python():
    assert problems({"envelope": {"psi": [-4, 4]}})[0].startswith("envelope.psi: envelope psi must span at most")
    (line,) = problems({"envelope": {"psi": [0, 100]}})  # beyond a full turn: degrees, said so
    assert line.startswith("envelope.psi: [0, 100] rad is more than a full turn") and "[0, 1.745] rad" in line
    with pytest.raises(ValueError, match="psi"):
        Envelope(u=(0, 1), v=(0, 1), r=(0, 1), psi=(0, 100))


def test_wrong_number_of_shape_vectors_at_construction():
    cfg = preset_config("paper-triangle")
    with pytest.raises(ConfigError, match="shape must have 2 rows"):
        replace(cfg, shape=((0.0, 10.0),))
    with pytest.raises(ConfigError, match="shape must have 3 rows"):
        replace(cfg, n=4)
    assert problems({"formation": {"n": 3, "offsets": [[0, 0], [1, 0]]}}) == [
        "formation.offsets must have 3 rows [x, y] for n = 3, got 2"
    ]


@pytest.mark.parametrize(
    "formation",
    [
        {"n": 3, "offsets": [[5, 5], [5, 5], [5, 5]]},  # all at one point
        {"n": 4, "offsets": [[0, 0], [10, 0], [0, 0], [3, 3]]},  # two of them coincide
        {"n": 3, "shape": [[0, 0], [20, 0]]},  # rho_1 = 0: vehicles 1 and 2 coincide
    ],
)
def test_coincident_vehicles_rejected(formation):
    (line,) = problems({"formation": formation})
    assert line.startswith("formation: vehicles ") and "same desired position" in line


def test_coincident_vehicles_rejected_in_python():
    with pytest.raises(ConfigError, match="same desired position"):
        replace(preset_config("paper-triangle"), shape=((0.0, 0.0), (0.0, 0.0)))


def test_exactly_one_shape_source():
    (line,) = problems({"formation": {"n": 3, "polygon_radius": 5.0, "shape": [[0, 1], [2, 0]]}})
    assert "exactly one of shape, offsets, polygon_radius" in line


def test_offsets_and_polygon_agree():
    a = config_from_dict({"formation": {"n": 3, "offsets": [[0, 10], [0, 0], [20, 5]]}})
    b = config_from_dict({"formation": {"n": 3, "offsets": [[100, 110], [100, 100], [120, 105]]}})
    assert np.allclose(a.shape, b.shape) and np.allclose(a.shape[0], (0.0, 10.0))
    assert config_from_dict({}).shape == config_from_dict({"formation": {"polygon_radius": 15}}).shape


def test_design_ranges_in_python():
    cfg = preset_config("paper-triangle")
    for kwargs, pattern in [({"gamma": 0.0}, "design.gamma must be >= 1e-06"),
                            ({"lam": 1e-9}, "design.lambda must be < 0"), ({"k1": -1}, "design.k1"),
                            ({"heading_poles": (-1.0, -1.0)}, "distinct"),
                            ({"method": "fast"}, "design.method must be one of")]:  # fmt: skip
        with pytest.raises(ConfigError, match=pattern):
            replace(cfg, **kwargs)
    with pytest.raises(ConfigError, match=r"design\.method"):
        cfg.with_method("nope")
    assert cfg.with_method("minimal").method == "minimal"


def test_reference_tables():
    assert config_from_dict({}).reference == ReferenceConfig(
        "sine", (("speed", 1.0), ("amplitude", 30.0), ("omega", 0.1))
    )
    ref = config_from_dict({"reference": {"kind": "lawnmower", "leg_length": 100, "spacing": 40, "turn_radius": 10}})
    assert ref.reference.kwargs() == {"speed": 1.0, "leg_length": 100.0, "spacing": 40.0, "turn_radius": 10.0}
    (line,) = problems({"reference": {"kind": "lawnmower", "leg_length": 100, "spacing": 20, "turn_radius": 10}})
    assert line.startswith("reference.spacing must be >= 39.7032 m") and "turn_radius to at most 5.037 m" in line
    # the bounds are written outwards: the spacing and the radius printed pass as written (30 m turns need
    # 119.10926... m, which 6 digits to nearest would print as 119.109, itself refused)
    lawn = {"kind": "lawnmower", "leg_length": 100, "turn_radius": 30}
    (line,) = problems({"reference": {**lawn, "spacing": 119.109}})
    need = float(line.split(">= ")[1].split(" m")[0])
    radius = float(line.split("at most ")[1].split(" m")[0])
    assert config_from_dict({"reference": {**lawn, "spacing": need}}).reference.kwargs()["spacing"] == need
    assert (
        config_from_dict({"reference": {**lawn, "spacing": 119.109, "turn_radius": radius}}).reference.kind
        == "lawnmower"
    )
    assert problems({"reference": {"kind": "circle"}}) == ["reference.radius is required"]
    # a blend shorter than the finest sample time, or longer than any run, names its key (1e300 s
    # overflowed the shaped start's closed forms, "(34, 'Numerical result out of range')")
    assert problems({"simulation": {"blend_time": 1e300}})[0].startswith("simulation.blend_time must be <=")
    assert problems({"simulation": {"blend_time": 1e-300}})[0].startswith("simulation.blend_time must be >=")
    assert problems({"reference": {"kind": "spiral"}})[0].startswith("reference.kind must be one of")
    assert problems({"reference": {"speed": 0}}) == ["reference.speed must be >= 0.001 [m/s], got 0"]
    assert problems({"reference": {"speed": 1e-300}}) == ["reference.speed must be >= 0.001 [m/s], got 1e-300"]
    with pytest.raises(ConfigError, match=r"reference\.radius must be > 0"):
        ReferenceConfig("circle", {"radius": -1.0})  # type: ignore[arg-type]


def test_simulation_uncertainty_disturbance():
    data = {
        "formation": {"n": 2, "polygon_radius": 5.0},
        "simulation": {"horizon": 2, "start": "paper", "initial": [[0, 0, 0, 1, 0, 0], [5, 0, 0, 1, 0, 0]],
                       "current": [0.1, 0], "blend_time": 30,
                       "plant": {"m22": 1.1, "d22_quad": 0.8}},
        "uncertainty": {"m11": [0.9, 1.1]},
        "disturbance": {"current_speed": 0.3},
        "actuators": {"tau_x": 500, "tau_y": 500, "tau_psi": 200},
    }  # fmt: skip
    cfg = config_from_dict(data)
    sim = cfg.simulation
    assert sim.horizon == 2.0 and sim.start == "paper" and cfg.actuators is not None
    assert cfg.actuators.limits() == (500.0, 500.0, 200.0)
    assert sim.initial == ((0.0, 0.0, 0.0, 1.0, 0.0, 0.0), (5.0, 0.0, 0.0, 1.0, 0.0, 0.0))
    plant = sim.plant_params(cfg.vehicle)
    assert plant.m22 == pytest.approx(1.1 * 250) and plant.d22_quad == pytest.approx(0.8 * 200) and plant.m11 == 200
    assert cfg.uncertainty.to_dict() == {"m11": [0.9, 1.1]}
    assert cfg.disturbance == DisturbanceConfig(current_speed=0.3)
    bad = {**data, "simulation": {**data["simulation"], "initial": [[0, 0, 0, 1, 0, 0]]}}
    assert "simulation.initial must have one row per vehicle (2), got 1" in problems(bad)
    assert problems({"uncertainty": {"m11": [1.1, 1.2]}})[0].startswith("uncertainty.m11: a relative range")
    assert problems({"simulation": {"plant": {"m11": 0}}}) == ["simulation.plant.m11 must be >= 0.1, got 0"]
    with pytest.raises(ConfigError, match=r"simulation\.initial must have one row per vehicle"):
        replace(preset_config("paper-triangle"), simulation=SimulationConfig(initial=((0, 0, 0, 0, 0, 0),)))
    with pytest.raises(ConfigError, match="uncertainty"):
        UncertaintyConfig((("m11", (0.0, 1.0)),))


@pytest.mark.parametrize("name", PRESETS)
def test_presets_round_trip_through_toml_dict(name):
    cfg = preset_config(name)
    assert config_from_dict(cfg.to_toml_dict()) == cfg
    initial = cfg.simulation.initial
    assert cfg.to_dict()["simulation"]["initial"] == (None if initial is None else [list(r) for r in initial])


def test_custom_config_round_trips():
    data = {
        "vehicle": {**NINE, "name": "mine"},
        "formation": {"n": 4, "jacobi": "orthonormal", "polygon_radius": 8},
        "design": {"method": "minimal", "gamma": 0.4, "lambda": -1.5},
        "reference": {"kind": "circle", "radius": 40},
        "simulation": {"plant": {"m11": 1.2}},
        "uncertainty": {"d22_quad": [0.5, 2]},
        "disturbance": {"current_rate": 0.01},
    }
    cfg = config_from_dict(data, name="custom")
    assert cfg.vehicle.name == "mine" and cfg.lam == -1.5 and cfg.name == "custom"
    assert config_from_dict(cfg.to_toml_dict()) == cfg


def test_preset_contents():
    tri, hexa = preset_config("paper-triangle"), preset_config("paper-hexagon")
    assert tri.shape == ((0.0, 10.0), (20.0, 0.0)) and tri.n == 3 and tri.vehicle == paper2011()
    assert tri.simulation.initial == PAPER_TRIANGLE_INITIAL and tri.simulation.horizon == 300.0
    assert tri.simulation.start == "shaped" and tri.reference.kind == "sine"
    assert tri.envelope.u == (0.0, 3.5) and tri.envelope.v == (-1.5, 1.5) and tri.envelope.r == (-0.5, 0.5)
    assert hexa.n == 6 and hexa.simulation.initial == spread_start(hexa.shape, hexa.transform)
    radii = [math.hypot(x, y) for x, y, *_ in hexa.simulation.initial]
    assert radii == pytest.approx([1.5 * 15.0] * 6)
    with pytest.raises(ConfigError, match="expected one of: paper-triangle, paper-hexagon"):
        preset_config("nope")


def test_demo_envelope_keeps_the_paper_gains():
    """The presets widen sway to 1.5 m/s (the paper's start sits on |v| = 1); lambda and sigma,
    computed independently by brute force over the vertices, are those of the paper's envelope."""
    from itertools import product

    from auv_hinf.models.envelope import PAPER_ENVELOPE

    p = paper2011()

    def lam_sigma(env):
        lam = min(-(p.d11_lin + p.d11_quad * 3.5) / p.m11, -(p.d22_lin + p.d22_quad * max(map(abs, env.v))) / p.m22)
        worst = 0.0
        for u, v, r in product((0.0, 3.5), (0.0, max(map(abs, env.v))), env.r):
            b = np.array(
                [
                    [-(p.d11_lin + p.d11_quad * u) / p.m11, (p.m22 - p.m11) * r / p.m11],
                    [(p.m22 - p.m11) * r / p.m22, -(p.d22_lin + p.d22_quad * v) / p.m22],
                ]
            )
            worst = max(worst, np.linalg.norm(b - lam * np.eye(2), 2))
        return lam, worst

    demo = preset_config("paper-triangle").envelope
    assert lam_sigma(demo) == pytest.approx(lam_sigma(PAPER_ENVELOPE), rel=1e-12)
    assert demo.v == (-1.5, 1.5) and PAPER_ENVELOPE.v == (-1.0, 1.0)


@pytest.mark.parametrize("speed", [0.375, 0.75, 2.0])
def test_a_speed_linearised_preset_takes_the_missions_speed_and_round_trips(speed):
    """A REMUS 100's lift ``Y_uv u v`` and ``N_ur u r`` are linear damping at its surge speed: a mission at
    ``speed`` gets ``d22_lin = 28.6 speed``, not the 1.5 m/s default (a review was advised a quarter of the
    speed and certified with the damping of the full one). The BlueROV2 has no lift terms and does not move."""
    line = {"kind": "line", "speed": speed}
    cfg = config_from_dict({"vehicle": {"preset": "remus100"}, "envelope": {"u": [0.2, 2.5]}, "reference": line})
    assert cfg.vehicle.d22_lin == pytest.approx(28.6 * speed) and cfg.vehicle.d33_lin == pytest.approx(2.0 * speed)
    assert cfg.to_toml_dict()["vehicle"] == {"preset": "remus100"}
    assert config_from_dict(cfg.to_toml_dict()) == cfg
    assert config_from_dict(tomllib.loads(annotated_toml(cfg))).vehicle == cfg.vehicle
    faster = with_settings(cfg, [("reference", "speed", 1.5)])  # a re-run at another speed re-linearises
    assert faster.vehicle.d22_lin == pytest.approx(28.6 * 1.5)
    rov = config_from_dict({"vehicle": {"preset": "bluerov2-heavy"}, "reference": {"kind": "line", "speed": speed}})
    assert rov.vehicle == VEHICLE_PRESETS["bluerov2-heavy"]()


def test_vehicle_preset_literal_matches_registry():
    from typing import get_args

    assert set(get_args(VehiclePreset)) == set(VEHICLE_PRESETS) and len(PARAMETERS) == 9


@pytest.mark.parametrize("name", PRESETS)
def test_annotated_toml_loads_back(tmp_path, name):
    cfg = preset_config(name)
    text = annotated_toml(cfg)
    assert "# surge inertia" in text and "[kg]" in text and "> 0" in text
    f = tmp_path / "start.toml"
    f.write_text(text)
    loaded = load_config(f)
    assert loaded.name == "start" and replace(loaded, name=cfg.name) == cfg
    assert tomllib.loads(text)["design"]["method"] == cfg.method


def test_json_schema_has_units_and_forbids_extras():
    schema = json_schema()
    props = schema["properties"]
    assert set(props) >= {"vehicle", "formation", "envelope", "design", "reference", "simulation", "uncertainty",
                          "disturbance"}  # fmt: skip
    vehicle = schema["$defs"]["VehicleTable"]
    assert vehicle["additionalProperties"] is False
    m11 = next(s for s in vehicle["properties"]["m11"]["anyOf"] if s.get("type") == "number")
    assert vehicle["properties"]["m11"]["unit"] == "kg" and m11["minimum"] == 1e-6 and m11["maximum"] == 1e9
    assert "lambda" in schema["$defs"]["DesignTable"]["properties"]


def test_load_config_errors_name_the_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[design]\ngama = 1\n")
    with pytest.raises(ConfigError, match=r"bad.toml: design.gama is not a known key"):
        load_config(f)
    with pytest.raises(ConfigError, match="cannot read config"):
        load_config(tmp_path / "missing.toml")
    f.write_bytes(b"\xff\xfe")
    with pytest.raises(ConfigError, match="cannot read config"):
        load_config(f)


def test_formation_config_rejects_wrong_object_types():
    cfg = preset_config("paper-triangle")
    with pytest.raises(ConfigError, match="vehicle must be a VehicleParams"):
        replace(cfg, vehicle={"m11": 1})  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"formation\.n"):
        replace(cfg, n=True)
    assert isinstance(FormationConfig(name="x", vehicle=paper2011(), n=2, jacobi="paper", shape=((1, 0),),
                                      envelope=cfg.envelope), FormationConfig)  # fmt: skip


def test_annotated_toml_writes_a_declared_implementation_and_loads_it_back(tmp_path):
    impl = Implementation(0.1, 0.05, True, MeasurementNoise(0.1, 0.02, 0.02, 0.01))
    cfg = replace(preset_config("bluerov2-line"), implementation=impl)
    text = annotated_toml(cfg)
    parsed = tomllib.loads(text)["implementation"]
    assert parsed["sample_time"] == 0.1 and parsed["noise"]["position"] == 0.1
    f = tmp_path / "deployed.toml"
    f.write_text(text)
    assert load_config(f).implementation == impl


@pytest.mark.parametrize("kind", ["lmi", "deployed"])
def test_a_synthesis_without_the_robust_design_is_refused_not_ignored(kind):
    """Without ``robust = true`` the nominal Theorem 1 gains run, so a declared synthesis would go unused:
    the file is refused, naming the key that is missing; with it, or with the baseline, it is read."""
    (line,) = problems({"design": {"synthesis": kind}})
    assert f'synthesis = "{kind}" needs robust = true' in line and line.startswith("design")
    config_from_dict({"design": {"synthesis": kind, "robust": True}, "implementation": {"sample_time": 0.1}})
    config_from_dict({"design": {"synthesis": "bandwidth"}})


def test_uncommenting_an_optional_table_header_of_the_annotated_file_leaves_valid_toml():
    """``init`` writes absent optional tables with their header commented out and a note after it; a user
    who uncomments the header (and a key) must get TOML that parses, the note staying a comment."""
    text = annotated_toml(preset_config("paper-triangle"))
    headers = [line for line in text.splitlines() if line.startswith(("# [actuators]", "# [guidance]"))]
    assert len(headers) == 2, "the preset leaves both optional tables out"
    for header in headers:
        tomllib.loads(text.replace(header, header.removeprefix("# "), 1))


@pytest.mark.parametrize("name", ["remus-transit-ilos", "remus-survey-ilos", "bluerov2-line"])
def test_annotated_actuators_show_the_vehicles_own_actuation(name):
    cfg = preset_config(name)
    text = annotated_toml(cfg)
    table = text.split("\n[actuators]\n", 1)[1].split("\n\n", 1)[0]
    act = cfg.actuators
    assert f"# tau_x = {act.tau_x!r}" in table  # the vehicle's own thrust, not a stand-in
    if name.startswith("remus"):  # a torpedo: its rudder, and no sway force or yaw moment to copy
        assert '# kind = "underactuated"' in table and f"# rudder_yaw = {act.rudder_yaw!r}" in table
        assert "tau_y =" not in table and "tau_psi =" not in table
    else:
        assert f"# tau_y = {act.tau_y!r}" in table


def test_a_unit_slip_is_named_only_where_the_other_unit_is_plausible():
    from auv_hinf.config.schema import MIN_SLIP, unit_slip

    assert unit_slip("rad", 13.6) == ": it looks like degrees; 13.6 degrees is 0.2374 rad"
    assert unit_slip("rad", 0.9) == ""  # a rudder of 0.9 rad is too large, but 0.9 degrees is no likelier
    assert unit_slip("rad/s", [0.5, MIN_SLIP]).startswith(": it looks like deg/s")
    assert unit_slip("m", 90.0) == ""  # no other unit is likely for a length
