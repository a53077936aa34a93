"""The configuration reference (``docs/config.md``), rendered from the TOML schema.

Every table, key, type, unit, range and default on that page is read from the pydantic models of
:mod:`auv_hinf.config.schema` and :mod:`auv_hinf.config.schema`, so the page cannot drift from
the schema: ``tests/config/test_config_reference.py`` compares the stored page with
:func:`config_reference`. Regenerate it with::

    .venv/bin/python -c "from auv_hinf.config.reference_doc import write_config_reference; write_config_reference()"
"""

from __future__ import annotations

import types
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from auv_hinf.config.presets import toml_literal
from auv_hinf.config.schema import ConfigFile, DesignTable, schema_default

#: Where the rendered page lives, relative to the repository root.
PAGE = Path("docs") / "config.md"

#: Comparison operators of pydantic's numeric constraints, in the order they are shown.
_OPERATORS = (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<="))

_Table = tuple[tuple[str, ...], type[BaseModel]]
_UNIONS = (Union, types.UnionType)

#: TOML names of the scalar Python types.
_SCALARS: dict[Any, str] = {float: "float", int: "integer", bool: "boolean", str: "string"}

#: A small configuration that validates: every table left out takes its defaults.
EXAMPLE_TOML = """\
name = "survey-square"

[vehicle]
preset = "remus100"

[formation]
n = 4
polygon_radius = 20.0

[envelope]
u = [0.5, 2.5]
v = [-0.3, 0.3]
r = [-0.3, 0.3]

[reference]
kind = "line"
speed = 1.5
"""

_INTRO = """\
# Configuration reference

A configuration is one TOML file, read by `auv-hinf certify`, `simulate` and `campaign` with
`--config FILE` (the built-in presets are the same objects, chosen with `--preset NAME`).
`auv-hinf init --out my_fleet.toml` writes an annotated starting file and `auv-hinf schema`
prints the JSON Schema of the format. From Python, {func}`~auv_hinf.config.settings.load_config`
reads a file into a {class}`~auv_hinf.config.settings.FormationConfig`.

This page is generated from the schema ({mod}`auv_hinf.config.schema`, the single source of every
default) by {func}`~auv_hinf.config.reference_doc.config_reference`;
`tests/config/test_config_reference.py` fails when it is out of date.

**Rules.** Every table and every key is optional unless its default reads *required*. A key
that is not listed here is an error, with a "did you mean" hint. Types are strict: a string is
never read as a number and a float never as an integer (an integer is fine where a float is
expected); NaN and infinities are refused. Units are SI and stated per key; *not set* means the
key is absent and the description says what is used instead. Each problem is reported on one
line naming its TOML path (`design.gamma`), and the command exits with code 2.

**Defaults are the same for every command.** The defaults below are the ones `design`,
`certify`, `simulate`, `campaign` and the Python API use. In particular `[design] k1`, the
Theorem 2 position gain, defaults to @K1@ 1/s^2 everywhere: in a file without it, in the
presets, and as the default of `auv-hinf design --k1`. Only the robust design
(`[design] robust = true`) picks its own `k1`, together with `alpha` and the heading gains.

**The default start.** Without `[simulation] initial` every vehicle starts on its slot: at
its desired position on the raw mission at t = 0, heading along the path, with the path's
speed as surge and its turn rate as yaw rate. That start has zero tracking error, so the
closed-loop certificate covers it at every fleet size without a blended start, and `certify`
and `simulate` judge the same start. A declared `initial` is checked as given, in the
`[simulation] start` mode that `simulate` runs: `"shaped"` (the default) blends the reference from
it when it is off the slots, `"paper"` tracks the raw mission from it; a raw start that only the
blend covers is refused with `start = "shaped"` as the answer.
A `[guidance]` fleet (propeller and rudder) starts on its slots heading into the current it runs
in (its crab), the ILOS state holding it. A declared `initial` is judged in *every* current up to
`[disturbance] current_speed`: a heading that is the crab of one current is a heading error in
the others, so even a start written on the slots for the configured current can be refused where
the default start certifies; the refusal then answers with `[simulation] initial` removed.

## A minimal file

Tables that are left out take their defaults (the paper's vehicle, a triangle, the paper's
envelope and its sine path). This file describes four REMUS-100 vehicles on a square that
follow a straight line at 1.5 m/s:

```toml
@EXAMPLE@```
"""


def _number(value: float) -> str:
    """A compact form of a bound: ``0``, ``2``, ``1e6``, ``0.5``."""
    return f"{value:g}".replace("e+0", "e").replace("e+", "e")


def _bounds(metadata: list[Any]) -> list[str]:
    """The numeric constraints (gt, ge, lt, le) in ``metadata`` as one entry, ``[">= 2, <= 1e5"]``."""
    parts = [f"{op} {_number(getattr(m, k))}" for m in _flat(metadata) for k, op in _OPERATORS if hasattr(m, k)]
    return [", ".join(parts)] if parts else []


def _flat(metadata: list[Any]) -> list[Any]:
    """Constraint objects of ``metadata``, with those of nested ``FieldInfo`` items spliced in."""
    return [m for item in metadata for m in (_flat(item.metadata) if isinstance(item, FieldInfo) else [item])]


def describe_type(tp: Any, metadata: list[Any] | None = None) -> tuple[str, list[str]]:
    """The TOML type of an annotation and the constraints it carries.

    Parameters
    ----------
    tp : type
        A field annotation: a scalar type, ``Literal``, ``list``, ``Annotated``, an optional
        (``X | None``) or a table model.
    metadata : list, optional
        Constraints attached to the field itself (pydantic's ``FieldInfo.metadata``).

    Returns
    -------
    tuple of (str, list of str)
        The type as shown (``float``, ``[float, float]``, ``list of [float, float]``,
        ``table``) and its allowed range, one entry per level of constraints.
    """
    meta = list(metadata or [])
    if get_origin(tp) is Annotated:
        base, *extra = get_args(tp)
        return describe_type(base, meta + extra)
    if get_origin(tp) in _UNIONS:
        members = [a for a in get_args(tp) if a is not type(None)]
        if len(members) == 1:
            return describe_type(members[0], meta)
        return "table", []
    if get_origin(tp) is Literal:
        choices = [f"`{toml_literal(c)}`" for c in get_args(tp)]
        return "string", ["one of " + ", ".join(choices)] if len(choices) > 1 else choices
    if get_origin(tp) is list:
        item, inner = describe_type(get_args(tp)[0])
        low = next((m.min_length for m in _flat(meta) if hasattr(m, "min_length")), None)
        high = next((m.max_length for m in _flat(meta) if hasattr(m, "max_length")), None)
        ranges = [r if r.startswith("each ") else f"each {r}" for r in inner]
        if low is not None and low == high:
            text = "[" + ", ".join([item] * low) + "]" if low <= 3 else f"[{low} x {item}]"
        else:
            text = f"list of {item}"
            ranges += [f"length >= {low}"] if low is not None else []
            ranges += [f"length <= {high}"] if high is not None else []
        return text, ranges + _bounds(meta)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return "table", []
    return _SCALARS.get(tp, getattr(tp, "__name__", str(tp))), _bounds(meta)


def _table_model(info: FieldInfo) -> list[type[BaseModel]]:
    """The table models a field holds: one, several (a tagged union), or none (a plain key)."""
    tp = info.annotation
    if get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    members = get_args(tp) if get_origin(tp) in _UNIONS else (tp,)
    return [m for m in members if isinstance(m, type) and issubclass(m, BaseModel)]


def walk_tables(model: type[BaseModel] = ConfigFile, path: tuple[str, ...] = ()) -> list[_Table]:
    """Every table of the configuration file, depth first in schema order.

    Parameters
    ----------
    model : type of BaseModel
        The table to start from (the whole file by default).
    path : tuple of str
        Its TOML path (empty for the top level).

    Returns
    -------
    list of (tuple of str, type of BaseModel)
        ``(path, model)`` pairs. A tagged union such as ``[reference]`` gives one pair per
        variant, all with the same path.
    """
    out = [(path, model)]
    for name, info in model.model_fields.items():
        for sub in _table_model(info):
            out += walk_tables(sub, (*path, info.alias or name))
    return out


def plain_keys(model: type[BaseModel]) -> list[tuple[str, FieldInfo]]:
    """The keys of a table that hold values, not sub-tables, with their field definitions.

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The table's model.
    """
    return [(info.alias or name, info) for name, info in model.model_fields.items() if not _table_model(info)]


def _cell(text: str) -> str:
    """Text made safe inside a Markdown table cell (``|`` escaped, reST literals as code)."""
    return text.replace("``", "`").replace("|", "\\|")


def _default(info: FieldInfo) -> str:
    if info.is_required():
        return "*required*"
    if info.default is None:
        return "*not set*"
    return f"`{toml_literal(info.default)}`"


def key_row(key: str, info: FieldInfo, default: str | None = None) -> str:
    """One row of a table's key list: key, type, unit, range, default and description.

    Parameters
    ----------
    key : str
        The TOML key (the field's alias when it has one).
    info : FieldInfo
        The field definition.
    default : str, optional
        Text of the default column, when the field's own default is not what a file gets.

    Returns
    -------
    str
        A Markdown table row.
    """
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    unit = str(extra.get("unit") or "")
    text = info.description or ""
    if unit and text.endswith(f" [{unit}]"):
        text = text[: -len(unit) - 3]
    kind, ranges = describe_type(info.annotation, list(info.metadata))
    cells = [f"`{key}`", kind, f"`{unit}`" if unit else "-", "; ".join(ranges) or "-", default or _default(info), text]
    return "| " + " | ".join(_cell(c) for c in cells) + " |"


def _summary(model: type[BaseModel]) -> str:
    """The first paragraph of a table's docstring, without its leading ``[table]:`` tag."""
    first = (model.__doc__ or "").strip().split("\n\n")[0].replace("\n", " ")
    if first.startswith("``[") and "]``: " in first:
        first = first.split("]``: ", 1)[1]
    first = first[:1].upper() + first[1:]
    return first.replace("``", "`")


def _key_table(model: type[BaseModel], kind: str | None = None) -> list[str]:
    """The key list of a table; ``kind``, for a tagged union, is the default of its ``kind`` key."""
    rows = ["| key | type | unit | range | default | description |", "|---|---|---|---|---|---|"]
    keys = sorted(plain_keys(model), key=lambda kv: kv[0] != "kind")
    return [*rows, *(key_row(key, info, kind if key == "kind" else None) for key, info in keys)]


def _when_absent(path: tuple[str, ...]) -> Any:
    """What a file without the table ``path`` gets: the instance its parent's default factory makes."""
    model: type[BaseModel] = ConfigFile
    info: FieldInfo | None = None
    for part in path:
        info = next(f for name, f in model.model_fields.items() if (f.alias or name) == part)
        model = _table_model(info)[0]
    factory = info.default_factory if info is not None else None
    return factory() if callable(factory) else None  # type: ignore[call-arg]


def _section(path: tuple[str, ...], models: list[type[BaseModel]]) -> list[str]:
    """The Markdown of one table (one subsection per variant of a tagged union)."""
    if not path:
        lines = ["## Top level", "", "Keys outside any table."]
        return [*lines, "", *_key_table(models[0]), ""]
    title = ".".join(path)
    absent = _when_absent(path)
    given = sorted(absent.model_fields_set) if isinstance(absent, BaseModel) else []
    note = ", ".join(f"`{k} = {toml_literal(getattr(absent, k))}`" for k in given)
    lines = [f"## `[{title}]`", ""]
    if len(models) == 1:
        lines += [_summary(models[0]), *([f"Without the table: {note}."] if note else []), ""]
        return [*lines, *_key_table(models[0]), ""]
    fallback = getattr(absent, "kind", None)
    lines += [
        f"`[{title}]` takes one of {len(models)} forms, chosen by `kind`; each has its own keys. "
        f"Without the table, or without `kind`, it is the `kind = {toml_literal(fallback)}` form.",
        "",
    ]
    for model in models:
        kind = model.model_fields["kind"].default
        shown = f"`{toml_literal(kind)}`" if kind == fallback else "*required*"
        lines += [f"### `kind = {toml_literal(kind)}`", "", _summary(model), "", *_key_table(model, shown), ""]
    return lines


def config_reference() -> str:
    """Markdown reference of the TOML configuration file, rendered from the schema.

    Returns
    -------
    str
        The text of ``docs/config.md``: an introduction, a minimal example and, per table,
        every key with its type, unit, allowed range, default and description.

    Examples
    --------
    >>> text = config_reference()
    >>> "## `[design]`" in text and "| `k1` | float |" in text
    True
    """
    k1 = schema_default(DesignTable, "k1")
    lines = [_INTRO.replace("@K1@", _number(k1)).replace("@EXAMPLE@", EXAMPLE_TOML)]
    grouped: dict[tuple[str, ...], list[type[BaseModel]]] = {}
    for path, model in walk_tables():
        grouped.setdefault(path, []).append(model)
    for path, models in grouped.items():
        lines += _section(path, models)
    return "\n".join(lines).rstrip("\n") + "\n"


def write_config_reference(root: str | Path = ".") -> Path:
    """Write :func:`config_reference` to ``docs/config.md`` under ``root``.

    Parameters
    ----------
    root : str or Path
        The repository root.

    Returns
    -------
    Path
        The page written.
    """
    page = Path(root) / PAGE
    page.write_text(config_reference(), encoding="utf-8")
    return page


__all__ = [
    "EXAMPLE_TOML",
    "PAGE",
    "config_reference",
    "describe_type",
    "key_row",
    "plain_keys",
    "walk_tables",
    "write_config_reference",
]
