"""docs/config.md is the configuration reference rendered from the schema, and it is complete.

The completeness check walks the pydantic models itself, without the generator, so a table or
key the generator skipped is caught.
"""

from __future__ import annotations

import re
import typing
from pathlib import Path

from pydantic import BaseModel

from auv_hinf.config.reference_doc import EXAMPLE_TOML, config_reference
from auv_hinf.config.schema import ConfigFile, DesignTable
from auv_hinf.config.settings import load_config

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "config.md"
REGENERATE = (
    '.venv/bin/python -c "from auv_hinf.config.reference_doc import config_reference; '
    "open('docs/config.md', 'w').write(config_reference())\""
)


def test_config_md_is_generated_from_the_schema():
    assert PAGE.read_text(encoding="utf-8") == config_reference(), (
        f"docs/config.md is out of date with the schema; regenerate it from the repository root with:\n{REGENERATE}"
    )


def _models(annotation: object) -> list[type[BaseModel]]:
    """Table models inside a field annotation (several for a tagged union such as [reference])."""
    if isinstance(annotation, type):
        return [annotation] if issubclass(annotation, BaseModel) else []
    return [m for arg in typing.get_args(annotation) for m in _models(arg)]


def _schema_tables(model: type[BaseModel], path: str = "") -> list[tuple[str, type[BaseModel], list[str]]]:
    """``(TOML path, model, keys)`` of every table below ``model``, keys with their aliases."""
    keys, out = [], []
    for name, field in model.model_fields.items():
        key = field.alias or name
        subs = _models(field.annotation)
        if subs:
            for sub in subs:
                out += _schema_tables(sub, f"{path}.{key}" if path else key)
        else:
            keys.append(key)
    return [(path, model, keys), *out]


def _sections(text: str) -> dict[str, str]:
    """Heading line -> text up to the next heading of any level."""
    parts = re.split(r"^(#{2,3} .*)$", text, flags=re.M)
    return {parts[i].strip(): parts[i + 1] for i in range(1, len(parts), 2)}


def test_every_table_and_key_of_the_schema_is_documented():
    sections = _sections(PAGE.read_text(encoding="utf-8"))
    tables = _schema_tables(ConfigFile)
    assert {"vehicle", "formation", "envelope", "design", "reference", "simulation", "simulation.plant"} <= {
        p for p, _, _ in tables
    }
    assert sum(p == "reference" for p, _, _ in tables) == 4, "one [reference] model per mission kind"
    missing = []
    for path, model, keys in tables:
        if not path:
            heading = "## Top level"
        elif "kind" in model.model_fields and path == "reference":
            heading = f'### `kind = "{model.model_fields["kind"].default}"`'
        else:
            heading = f"## `[{path}]`"
        body = sections.get(heading)
        if body is None:
            missing.append(f"section {heading!r}")
            continue
        missing += [f"{path or '(top level)'}.{k}" for k in keys if f"| `{k}` |" not in body]
    assert not missing, f"not documented in docs/config.md: {missing}"


def test_config_md_states_units_ranges_and_the_k1_default():
    text = PAGE.read_text(encoding="utf-8")
    k1 = DesignTable.model_fields["k1"].default
    assert k1 == 0.5
    assert f"`[design] k1`, the\nTheorem 2 position gain, defaults to {k1:g} 1/s^2" in text
    design = _sections(text)["## `[design]`"]
    assert "| `k1` | float | `1/s^2` | > 0, <= 1e6 | `0.5` |" in design
    assert "| `lambda` | float | `1/s` | >= -1e6, < 0 | *not set* |" in design
    assert '| `method` | string | - | one of `"paper"`, `"stabilizing"`, `"minimal"` |' in design


def test_the_example_file_is_valid(tmp_path):
    assert f"```toml\n{EXAMPLE_TOML}```" in PAGE.read_text(encoding="utf-8")
    path = tmp_path / "example.toml"
    path.write_text(EXAMPLE_TOML, encoding="utf-8")
    cfg = load_config(path)
    assert cfg.n == 4 and cfg.reference.kind == "line"
