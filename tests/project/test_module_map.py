"""docs/modules.md names every public module of the package, and only modules that exist."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import auv_hinf

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "modules.md"
#: A module named in the first cell of a table row, as a {mod} role or as code.
ROW = re.compile(r"^\| (?:\{mod\})?`(auv_hinf(?:\.\w+)*)` \|", re.M)
#: Every {mod} role anywhere on the page.
ROLE = re.compile(r"\{mod\}`~?(auv_hinf(?:\.\w+)*)`")


def public_modules() -> set[str]:
    return {
        m.name
        for m in pkgutil.walk_packages(auv_hinf.__path__, "auv_hinf.")
        if not any(part.startswith("_") for part in m.name.split("."))
    }


def test_walk_finds_the_subpackages():
    found = public_modules()
    for pkg in (
        "numerics",
        "models",
        "mission",
        "law",
        "actuation",
        "implementation",
        "simulation",
        "design",
        "closed_loop",
        "robust",
        "config",
        "certificate",
        "certificate.parts",
        "deployment",
        "campaign",
        "figures",
        "cli",
    ):
        assert f"auv_hinf.{pkg}" in found
    assert len(found) > 50


def test_every_public_module_is_on_the_map():
    listed = set(ROW.findall(PAGE.read_text(encoding="utf-8")))
    missing = sorted(public_modules() - listed)
    assert not missing, f"modules missing from docs/modules.md (add a row to its subpackage's table): {missing}"


def test_every_module_on_the_map_exists():
    text = PAGE.read_text(encoding="utf-8")
    named = set(ROW.findall(text)) | set(ROLE.findall(text))
    assert named, "docs/modules.md names no module"
    gone = []
    for name in sorted(named):
        try:
            importlib.import_module(name)
        except ImportError:
            gone.append(name)
    assert not gone, f"docs/modules.md names modules that do not exist: {gone}"


def test_each_module_is_listed_under_its_own_subpackage():
    """A row sits in the table of the subpackage that contains the module."""
    sections = re.split(r"^## ", PAGE.read_text(encoding="utf-8"), flags=re.M)[1:]
    misplaced = []
    for section in sections:
        title = re.match(r"`(auv_hinf(?:\.\w+)*)`", section)
        if title is None:
            continue
        pkg = title.group(1)
        for name in ROW.findall(section):
            if name != pkg and not name.startswith(pkg + ".") and pkg != "auv_hinf":
                misplaced.append(f"{name} under {pkg}")
    assert not misplaced, misplaced
