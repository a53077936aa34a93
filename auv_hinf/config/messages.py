"""What the user is told about their input: one readable line per problem, and warnings.

Pydantic's errors are rewritten as ``design.gamma must be > 0.0 s, got -1``,
``design.gama is not a known key; did you mean 'gamma'?`` or
``[extra] is an unknown table; expected one of: ...`` and raised together as one
:class:`~auv_hinf.exceptions.ConfigError`. Every line names the TOML path of what the user
typed (``reference.spacing``), never a Python class.

Numbers that look like another unit are errors, raised by the schema
(:data:`~auv_hinf.config.schema.MAX_ANGLE`, :data:`~auv_hinf.config.schema.MAX_RATE`,
:data:`~auv_hinf.config.schema.MAX_SPEED`): the line names the key, the value, the likely unit
and the value converted (``reference.heading must be <= 6.28319 [rad], got 90.0: it looks like
degrees; 90 degrees is 1.571 rad``). They are errors rather than warnings because read in the
documented unit they certify or simulate another mission without a word, and a warning is not
seen from Python or in a CI log.

:func:`input_warnings` flags input that validates and is meaningful but is probably not what
the user meant; the CLI prints the lines on standard error before it runs: a configuration
file that sets nothing, so every default is certified without a word.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from pydantic import BaseModel, ValidationError

from auv_hinf.config.schema import TABLES, ConfigFile, DesignTable, schema_default, suggest_key, table_keys, unit_slip
from auv_hinf.exceptions import AuvHinfError, ConfigError

_TYPE_NAMES = {
    "float_type": "a number",
    "bool_type": "true or false",
    "int_type": "an integer",
    "string_type": "a string",
    "list_type": "an array",
    "model_type": "a table",
    "model_attributes_type": "a table",
    "dict_type": "a table",
}


_BOUNDS = {
    "greater_than": ("gt", ">"),
    "greater_than_equal": ("ge", ">="),
    "less_than": ("lt", "<"),
    "less_than_equal": ("le", "<="),
}


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _locate(loc: tuple[Any, ...]) -> tuple[tuple[str, ...], tuple[Any, ...], list[Any]]:
    """Split a pydantic location into (table path, rest, displayed location without union tags)."""
    table: tuple[str, ...] = ()
    shown: list[Any] = []
    i = 0
    while i < len(loc):
        if (*table, loc[i]) in TABLES:
            table, i = (*table, loc[i]), i + 1
            shown.append(loc[i - 1])
        elif i + 1 < len(loc) and (*table, loc[i], loc[i + 1]) in TABLES:  # discriminated union tag
            table, i = (*table, loc[i], loc[i + 1]), i + 2
            shown.append(loc[i - 2])
        else:
            break
    return table, tuple(loc[i:]), shown + list(loc[i:])


def _path(parts: list[Any]) -> str:
    out = ""
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _unknown(table: tuple[str, ...], key: str, value: Any, path: str) -> str:
    model = TABLES[table]
    if table:
        return f"{path} is not a known key{suggest_key(key, table_keys(model))}"
    if isinstance(value, dict):
        return f"[{key}] is an unknown table{suggest_key(key, table_keys(model))}"
    homes = [".".join(t) for t, m in TABLES.items() if t and key in table_keys(m)]
    hint = f"; it belongs in [{homes[0]}]" if homes else suggest_key(key, table_keys(model))
    return f"{key} is not a known top-level key{hint}"


def _message(err: Any) -> str:
    table, rest, shown = _locate(tuple(err["loc"]))
    path, kind, value, ctx = (
        _path(shown),
        err["type"],
        err.get("input"),
        err.get("ctx") or {},
    )
    if kind == "extra_forbidden":
        return _unknown(table, str(rest[-1]), value, path)
    if kind == "union_tag_invalid":
        return f"{path}.kind must be one of {ctx.get('expected_tags')}, got {ctx.get('tag')!r}"
    if kind == "missing":
        return f"{path} is required"
    if kind == "finite_number":
        return f"{path} must be finite, got {_show(value)}"
    if kind in _BOUNDS:
        fields = {f.alias or k: f for k, f in TABLES[table].model_fields.items()}
        info = fields.get(str(rest[0])) if rest else None
        extra = info.json_schema_extra if info is not None else None
        unit = str(extra["unit"]) if isinstance(extra, dict) and "unit" in extra else ""
        key, op = _BOUNDS[kind]
        limit = float(ctx[key])
        too_large = key in ("lt", "le") or limit < 0.0  # an upper bound, or a lower one such as -2 pi
        slip = unit_slip(unit, value) if too_large and isinstance(value, (int, float)) else ""
        return f"{path} must be {op} {limit:g}{f' [{unit}]' if unit else ''}, got {_show(value)}{slip}"
    if kind in ("too_short", "too_long"):
        n = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        bound = "at least" if kind == "too_short" else "at most"
        return f"{path} must have {bound} {n} items, got {ctx.get('actual_length')}"
    if kind == "string_too_short":
        return f"{path} must not be empty: leave it out for the default"
    if kind == "literal_error":
        return f"{path} must be one of {ctx.get('expected')}, got {_show(value)}"
    if kind in _TYPE_NAMES or kind.endswith("_type"):
        return f"{path} has the wrong type: expected {_TYPE_NAMES.get(kind, kind[:-5])}, got {_show(value)}"
    msg = str(err["msg"]).removeprefix("Value error, ")
    if table and not rest and msg.split(" ", 1)[0] in table_keys(TABLES[table]):  # a table's check names its key
        return f"{path}.{msg}"
    return f"{path}: {msg}" if path else msg


def format_errors(exc: ValidationError, where: tuple[str, ...] = ()) -> list[str]:
    """One readable line per problem of a pydantic ``ValidationError``, naming the TOML path.

    Parameters
    ----------
    exc : pydantic.ValidationError
        The validation error.
    where : tuple of str
        TOML path of the validated table, put before each error's own location.
    """
    lines: list[str] = []
    for err in exc.errors(include_url=False):
        line = _message({**err, "loc": (*where, *err["loc"])})
        if line not in lines:
            lines.append(line)
    return lines


def validate_table(model: type[BaseModel], data: Any, where: tuple[str, ...] = ()) -> Any:
    """Validate ``data`` with ``model``; problems become one :class:`ConfigError` (one line each).

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The table's model.
    data : Any
        The table's parsed content.
    where : tuple of str
        TOML path of the table (e.g. ``("design",)``), used in the messages.
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError("\n".join(format_errors(exc, where))) from None
    except AuvHinfError as exc:  # pragma: no cover - raised by constructors called in validators
        raise ConfigError(f"{'.'.join(where) or 'config'}: {exc}") from None


def parse_config(data: Any) -> ConfigFile:
    """Validate a parsed TOML document (a dict of tables).

    Parameters
    ----------
    data : Any
        The parsed document; anything but a dict is refused.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"a configuration must be a table of tables, got {type(data).__name__}")
    out: ConfigFile = validate_table(ConfigFile, data)
    return out


def plain_data(value: Any) -> Any:
    """Python or numpy values as TOML-like data (numbers, strings, lists, dicts) for validation.

    Numpy scalars become Python numbers, arrays and tuples become lists; booleans and
    strings are kept, so the strict models still refuse them where a number is expected.

    Parameters
    ----------
    value : Any
        The value, nested mappings and iterables included.
    """
    if isinstance(value, (bool, str, bytes)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    if isinstance(value, Mapping):
        return {k: plain_data(v) for k, v in value.items()}
    if isinstance(value, Iterable):
        return [plain_data(v) for v in value]
    return value


def as_dict(value: Any, where: str) -> dict[str, Any]:
    """``dict(value)`` for a mapping or (name, value) pairs, else a ConfigError.

    Parameters
    ----------
    value : Any
        A mapping or an iterable of ``(name, value)`` pairs.
    where : str
        What the value is (a TOML path), for the message.
    """
    try:
        return dict(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{where} must be a table or (name, value) pairs, got {value!r}") from None


def set_fields(obj: Any, **values: Any) -> None:
    """Normalise the fields of a frozen dataclass in its ``__post_init__``.

    Parameters
    ----------
    obj : Any
        The dataclass instance.
    **values : Any
        New values of its fields, by field name.
    """
    for key, val in values.items():
        object.__setattr__(obj, key, val)


def input_warnings(data: Any) -> list[str]:
    """One readable line per suspicious entry of a parsed TOML document (empty: nothing to say).

    Numbers in the wrong unit are not warnings but errors of the schema (see the module docstring).

    Parameters
    ----------
    data : dict
        The parsed configuration file.
    """
    if isinstance(data, dict) and not data:
        return ["the configuration file sets nothing: every table takes its defaults (see docs/config.md)"]
    out = []
    act = data.get("actuators") if isinstance(data, dict) else None
    sway, yaw = (act.get("rudder_sway"), act.get("rudder_yaw")) if isinstance(act, dict) else (None, None)
    if isinstance(sway, (int, float)) and isinstance(yaw, (int, float)) and float(sway) * float(yaw) > 0.0:
        out.append(
            f"actuators.rudder_sway ({sway:g}) and actuators.rudder_yaw ({yaw:g}) have one sign: the rudder's side "
            f"force then acts {yaw / sway:.3g} m ahead of the centre of mass, a bow rudder; a stern rudder's have "
            "opposite signs (a REMUS 100's: 9.64 kg/(m rad) and -6.15 kg/rad)"
        )
    guided = isinstance(data, dict) and isinstance(data.get("guidance"), dict)
    design = data.get("design") if guided else None
    if isinstance(design, dict):
        for key, default in GUIDED_UNUSED_DESIGN.items():
            if key in design and design[key] != default:
                out.append(
                    f"design.{key} is not used by a [guidance] fleet: its cascade (the [guidance] gains, the propeller "
                    "and the rudder) replaces the formation law whose gains [design] designs"
                )
    sim = data.get("simulation") if isinstance(data, dict) else None
    if guided and isinstance(sim, dict):
        for key, default in GUIDED_UNUSED.items():
            if key in sim and sim[key] != default:
                out.append(
                    f"simulation.{key} is not used by a [guidance] fleet: its cascade starts every vehicle on its slot "
                    "heading into the current (or from [simulation] initial), with no blended reference"
                )
    return out


#: ``[simulation]`` keys of the formation law's shaped start, which a ``[guidance]`` fleet does not read,
#: with the value ``auv-hinf init`` writes (not worth a warning).
GUIDED_UNUSED: dict[str, object] = {"start": "shaped", "blend_time": None}
#: ``[design]`` keys of the formation law's gain design, which a ``[guidance]`` fleet does not read, with
#: their defaults (not worth a warning).
GUIDED_UNUSED_DESIGN: dict[str, object] = {
    key: schema_default(DesignTable, key) for key in ("robust", "synthesis", "integral")
}


__all__ = [
    "GUIDED_UNUSED",
    "GUIDED_UNUSED_DESIGN",
    "as_dict",
    "format_errors",
    "input_warnings",
    "parse_config",
    "plain_data",
    "set_fields",
    "validate_table",
]
