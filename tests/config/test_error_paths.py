"""Every error of a configuration file names what the user typed: the TOML table and key, never a Python class.

The walk is generated from the schema: every key of every table gets a value of the wrong type, a value
past each of its bounds and a misspelling; every validator of every table gets a document that trips it
(a validator without one fails the test); the checks after the schema (the runtime configuration) get one
each. Each document is read by ``auv-hinf certify --config``, the way a user meets it.
"""

from __future__ import annotations

import re
import types
import typing
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import annotated_types
import pytest
from pydantic import BaseModel

from auv_hinf.cli.main import main
from auv_hinf.config.schema import MAX_ANGLE, PARAMETERS, TABLES
from auv_hinf.models.vehicle import paper2011
from tests.helpers import package_class_names, to_toml

#: The paper's vehicle as the nine parameters of ``[vehicle]``.
PAPER_PARAMETERS = {k: getattr(paper2011(), k) for k in PARAMETERS}
#: A value of the wrong type for each kind of field.
WRONG_TYPE = {"number": "fast", "string": 3.5, "bool": "yes", "list": "fast", "table": 3.5}


def _kind(annotation: Any) -> str:
    """``number``, ``string``, ``bool``, ``list`` or ``table``: what a field holds."""
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) is typing.Annotated:
        return _kind(args[0])
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return _kind(args[0])
    if typing.get_origin(annotation) is typing.Literal or annotation is str:
        return "string"
    if annotation is bool:
        return "bool"
    if annotation in (int, float):
        return "number"
    if typing.get_origin(annotation) is list:
        return "list"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "table"
    raise AssertionError(f"unknown field type {annotation!r}")


def _document(table: tuple[str, ...], entries: dict[str, Any]) -> dict[str, Any]:
    """A configuration setting ``entries`` in ``table`` (a reference kind gets its required keys)."""
    if table[:1] == ("reference",):
        required = {
            "circle": {"radius": 50.0},
            "lawnmower": {"leg_length": 200.0, "spacing": 100.0, "turn_radius": 20.0},
        }
        return {"reference": {"kind": table[1], **required.get(table[1], {}), **entries}}
    if table == ("vehicle",):  # the nine parameters, or a preset
        base = PAPER_PARAMETERS if entries.keys() & set(PARAMETERS) else {"preset": "paper2011"}
        return {"vehicle": {**base, **entries} if "preset" not in entries else entries}
    if table == ("actuators",):  # the three limits, or a preset
        base = {"tau_x": 86.0, "tau_y": 86.0, "tau_psi": 23.0} if "preset" not in entries else {}
        return {"actuators": {**base, **entries}}
    out: dict[str, Any] = entries
    for name in reversed(table):
        out = {name: out}
    return out


def _past_bounds(field: Any) -> Iterator[tuple[str, float]]:
    """``(bound, value)`` just past each of a field's bounds (gt: at it, ge: below it, ...), an int for an int."""
    kind = int if field.annotation is int else float
    for meta in field.metadata:
        for attr, step in (("gt", 0.0), ("ge", -1.0), ("lt", 0.0), ("le", 1.0)):
            bound = getattr(meta, attr, None)
            if isinstance(meta, annotated_types.BaseMetadata) and bound is not None:
                yield attr, kind(bound + step * max(1, abs(bound)))


def schema_cases() -> Iterator[tuple[str, dict[str, Any], str]]:
    """``(id, document, the TOML path the message must name)`` for every key of every table."""
    for table, model in TABLES.items():
        dotted = ".".join(table[:1] if table[:1] == ("reference",) else table)
        for name, field in model.model_fields.items():
            key = field.alias or name
            if key == "kind":
                continue
            path = f"{dotted}.{key}" if dotted else key
            if dotted or _kind(field.annotation) not in ("table",):
                yield f"{path} wrong type", _document(table, {key: WRONG_TYPE[_kind(field.annotation)]}), path
            for bound, value in _past_bounds(field):
                yield f"{path} past {bound}", _document(table, {key: value}), path
        if table:
            yield f"{dotted} misspelled key", _document(table, {"speeed": 1.0}), f"{dotted}.speeed"
    yield "unknown table", {"controler": {"k": 1.0}}, "[controler]"
    yield "misplaced key", {"gamma": 0.5}, "gamma"
    yield "unknown reference kind", {"reference": {"kind": "spiral"}}, "reference.kind"


ROWS = [[0.0, 0.0, 0.1, 1.0, 0.0, 0.0], [20.0, 0.0, 0.0, 1.0, 0.0, 0.0], [10.0, 15.0, 0.0, 1.0, 0.0, 0.0]]


#: One document per validator of the schema: (table, validator) -> (document, the key the message names).
VALIDATOR_CASES: dict[tuple[tuple[str, ...], str], tuple[dict[str, Any], str]] = {
    ((), "_initial_rows"): ({"simulation": {"initial": ROWS[:2]}}, "simulation.initial"),
    ((), "_actuators_of_the_vehicle"): (
        {"vehicle": {"preset": "remus100"}, "actuators": {"preset": "nps-auv2"}},
        "actuators.preset",
    ),
    ((), "_default_reference_kind"): ({"reference": {"omega": -1.0}}, "reference.omega"),
    (("vehicle",), "_preset_or_parameters"): ({"vehicle": {"preset": "remus100", "m11": 1.0}}, "vehicle.preset"),
    (("formation",), "_one_shape"): ({"formation": {"n": 3, "offsets": [[0, 0], [1, 0]]}}, "formation.offsets"),
    (("envelope",), "_interval"): ({"envelope": {"r": [0.5, -0.5]}}, "envelope.r"),
    (("design",), "_distinct"): ({"design": {"heading_poles": [-1.0, -1.0]}}, "design.heading_poles"),
    (("design",), "_integral_is_robust"): ({"design": {"integral": True}}, "integral"),
    (("simulation",), "_state_units"): ({"simulation": {"initial": [[0, 0, 90.0, 1, 0, 0], *ROWS[1:]]}}, "psi"),
    (("simulation",), "_current_speed"): ({"simulation": {"current": [0.0, 40.0]}}, "simulation.current"),
    (("simulation",), "_moved_thrust_limit"): ({"simulation": {"thrust_limit": 100.0}}, "[actuators]"),
    (("uncertainty",), "_box"): ({"uncertainty": {"m11": [1.1, 1.2]}}, "uncertainty.m11"),
    (("actuators",), "_one_source"): ({"actuators": {"tau_x": 10.0}}, "tau_psi"),
    (("implementation",), "_period"): ({"implementation": {"sample_time": 1e-300}}, "implementation.sample_time"),
    (("reference", "lawnmower"), "_turns_fit"): (
        {"reference": {"kind": "lawnmower", "leg_length": 100.0, "spacing": 20.0, "turn_radius": 10.0}},
        "reference.spacing",
    ),
}


#: The checks after the schema (the runtime configuration and what it builds), one document each.
RUNTIME_CASES: dict[str, tuple[dict[str, Any], str]] = {
    "speed far above the envelope": ({"reference": {"speed": 9.0}}, "reference.speed"),
    "integral action with a sampled law": (
        {"design": {"robust": True, "integral": True}, "implementation": {"sample_time": 0.1}},
        "design.integral",
    ),
    "heading in degrees": ({"reference": {"kind": "line", "heading": 4 * MAX_ANGLE}}, "reference.heading"),
}


def _validators(model: type[BaseModel]) -> set[str]:
    decorators = model.__pydantic_decorators__
    return {*decorators.field_validators, *decorators.model_validators}


def test_every_validator_of_the_schema_has_a_case():
    every = {(table, name) for table, model in TABLES.items() for name in _validators(model)}
    assert every == set(VALIDATOR_CASES), "add a case for each new validator (and remove those of deleted ones)"


def _class_names_in(text: str) -> list[str]:
    return [name for name in package_class_names() if re.search(rf"\b{re.escape(name)}\b", text)]


def test_the_class_names_are_found_in_a_message():
    assert _class_names_in("LawnmowerReference.spacing must be >= 79.4 m") == ["LawnmowerReference"]
    assert _class_names_in("reference.spacing must be >= 79.4 m") == []
    assert len(package_class_names()) > 100


CASES = [
    *schema_cases(),
    *((f"validator {t}.{v}", doc, key) for (t, v), (doc, key) in VALIDATOR_CASES.items()),
    *((f"runtime: {what}", doc, key) for what, (doc, key) in RUNTIME_CASES.items()),
]


@pytest.mark.slow
@pytest.mark.parametrize(("case", "document", "key"), CASES, ids=[c[0] for c in CASES])
def test_every_config_error_names_the_toml_key_and_no_class(case, document, key, tmp_path: Path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(to_toml(document), encoding="utf-8")
    assert main(["certify", "--config", str(path)]) == 2, case
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert out == "" and lines and "Traceback" not in err
    prefix = f"auv-hinf: error: --config {path}: "
    assert all(line.startswith(prefix) for line in lines), err
    assert any(key in line for line in lines), (key, err)
    assert _class_names_in(err) == [], err


@pytest.mark.parametrize("column, name", [(0, "x"), (1, "y")])
def test_a_start_position_beyond_any_formation_is_refused_with_its_row_and_unit(column, name, tmp_path: Path, capsys):
    """Regression: x = 1e9 m in ``[simulation] initial`` was accepted, and ``simulate`` ran for minutes."""
    from auv_hinf.config.schema import MAX_COORDINATE

    rows = [list(r) for r in ROWS]
    rows[1][column] = 10.0 * MAX_COORDINATE
    path = tmp_path / "far.toml"
    path.write_text(to_toml({"simulation": {"initial": rows}}))
    assert main(["certify", "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"simulation.initial: row 1 (vehicle 2), {name} = 1e+07 m" in err and "Traceback" not in err
    rows[1][column] = MAX_COORDINATE  # the largest coordinate accepted
    path.write_text(to_toml({"simulation": {"initial": rows}}))
    assert "simulation.initial" not in _config_error(path)


def _config_error(path: Path) -> str:
    """The message of the error loading ``path`` raises (empty when it loads)."""
    from auv_hinf.config.settings import load_config
    from auv_hinf.exceptions import ConfigError

    try:
        load_config(path)
    except ConfigError as exc:
        return str(exc)
    return ""
