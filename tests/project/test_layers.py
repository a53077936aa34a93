"""The packages import each other in one direction: every import goes to a package listed before its own.

The order is the data flow of a command (docs/modules.md): numerical building blocks, the
physical world, the mission, the law, actuation, the controller as it runs, the guidance cascade,
simulation, design, the certificates (the formation law's, then the guidance cascade's), configuration,
the assembled certificate, deployment on vehicles, campaigns, figures, CLI.
An import inside a function counts as much as one at the top of a module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "auv_hinf"

#: The packages from the bottom up; the private modules and ``exceptions`` are the ground.
LAYERS = (
    ("_typing", "_version", "exceptions", "files"),
    ("numerics",),
    ("models",),
    ("mission",),
    ("law",),
    ("actuation",),
    ("implementation",),
    ("guidance",),
    ("simulation",),
    ("design",),
    ("closed_loop",),
    ("robust",),
    ("composed",),
    ("cascade",),
    ("config",),
    ("certificate",),
    ("deployment",),
    ("campaign",),
    ("figures",),
    ("cli",),
)
#: Imports allowed against the order (``(from, to)`` package pairs), each with its reason. None.
ALLOWED_UPWARD: frozenset[tuple[str, str]] = frozenset()


def _level(package: str) -> int:
    for k, names in enumerate(LAYERS):
        if package in names:
            return k
    raise AssertionError(f"package {package!r} has no layer in tests/project/test_layers.py")


def _imports() -> list[tuple[str, str, str]]:
    """``(importing package, imported package, file)`` for every import between packages."""
    out = []
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE)
        if rel.parts == ("__init__.py",):
            continue  # the public API re-exports from every layer
        own = rel.parts[0].removesuffix(".py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            for name in names:
                parts = name.split(".")
                if parts[0] == "auv_hinf" and len(parts) > 1 and parts[1] != own:
                    out.append((own, parts[1], str(rel)))
    return out


def test_every_package_has_a_layer():
    found = {p.name.removesuffix(".py") for p in PACKAGE.iterdir() if p.name != "__init__.py" and p.name != "py.typed"}
    found.discard("__pycache__")
    for name in sorted(found):
        _level(name)


def test_imports_go_down_the_layers_only():
    upward = sorted(
        (src, dst, f)
        for src, dst, f in _imports()
        if _level(dst) >= _level(src) and (src, dst) not in ALLOWED_UPWARD and _level(src) > 0
    )
    assert not upward, f"imports against the layer order (package, imported package, file): {upward}"


@pytest.mark.slow
def test_the_check_sees_imports():
    pairs = {(s, d) for s, d, _ in _imports()}
    assert ("certificate", "closed_loop") in pairs and ("cli", "certificate") in pairs
    assert len(pairs) > 40
