"""Docstrings and documentation pages stay consistent with the code.

* every public function and class passes a chosen set of numpydoc checks;
* every public function and method of every module documents its parameters, and every
  public dataclass its fields;
* every test named in docs/ exists;
* every paper equation the package cites is on the equation map.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest
from numpydoc.docscrape import NumpyDocString
from numpydoc.validate import validate

import auv_hinf

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PACKAGE = ROOT / "auv_hinf"

#: numpydoc checks every public object must pass. Left out on purpose: ES01 (extended
#: summary), EX01 (examples), SA01 (see also), RT01 (returns section: one-line
#: docstrings of small functions state the result). PR01 (every parameter documented) is
#: enforced for functions and methods (:data:`CALLABLE_CHECKS`), not for classes: dataclasses
#: document their fields under "Attributes", which :func:`test_dataclass_fields_documented`
#: checks instead. PR03, PR04, PR07 and SS05 are not enforced yet either.
NUMPYDOC_CHECKS = frozenset(
    {
        "GL02",  # closing quotes on their own line
        "GL03",  # double line break
        "GL05",  # tabs
        "GL06",  # unknown section
        "GL07",  # sections in the wrong order
        "GL08",  # no docstring
        "GL09",  # deprecation warning misplaced
        "GL10",  # reST directive without a double colon
        "SS01",  # no summary
        "SS02",  # summary not starting with a capital
        "SS03",  # summary not ending with a period
        "SS04",  # summary with heading whitespace
        "SS06",  # summary over several lines
        "PR02",  # documented parameter that does not exist
        "PR05",  # parameter type ending with a period
        "PR06",  # "integer", "boolean", "string" instead of int, bool, str
        "PR08",  # parameter description not starting with a capital
        "PR09",  # parameter description not ending with a period
        "PR10",  # colon without a space before it
        "RT02",  # returns section naming a variable for a single value
        "RT03",  # return value without a description
        "RT04",  # return description not starting with a capital
        "RT05",  # return description not ending with a period
        "YD01",  # generator without a yields section
    }
)


def public_objects() -> list[str]:
    names = []
    for name in auv_hinf.__all__:
        obj = getattr(auv_hinf, name)
        if inspect.isfunction(obj) or inspect.isclass(obj):
            names.append(name)
    return names


def test_the_lazy_public_names_are_the_listed_ones():
    """Every name of ``__all__`` is imported on first use from one module, and nothing else is."""
    assert set(auv_hinf.__all__) == {"__version__", *auv_hinf._HOME}
    assert len(auv_hinf._HOME) == sum(len(names) for names in auv_hinf._LAZY.values())  # each name in one module


@pytest.mark.parametrize("name", public_objects())
def test_numpydoc(name):
    obj = getattr(auv_hinf, name)
    result = validate(f"{obj.__module__}.{obj.__qualname__}")
    errors = [f"{code}: {msg}" for code, msg in result["errors"] if code in NUMPYDOC_CHECKS]
    assert not errors, f"{name}: " + "; ".join(errors)


#: Checks of every public function and method: the class set plus PR01 (parameters not documented).
CALLABLE_CHECKS = NUMPYDOC_CHECKS | {"PR01"}


def public_modules() -> list[str]:
    """Every module of the package without a private part in its name (as tests/project/test_module_map.py)."""
    return sorted(
        m.name
        for m in pkgutil.walk_packages(auv_hinf.__path__, "auv_hinf.")
        if not any(part.startswith("_") for part in m.name.split("."))
    )


def exported() -> list[tuple[str, object]]:
    """``(module.name, object)`` of every name in a module's ``__all__`` that the module defines itself."""
    out = []
    for module in public_modules():
        mod = importlib.import_module(module)
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == module:
                out.append((f"{module}.{name}", obj))
    return out


def public_callables() -> list[str]:
    """Import paths of every exported function and every public method of an exported class.

    Methods are the functions, static methods and class methods defined in the class body
    whose names do not start with ``_`` (properties and dunder methods are not included).
    """
    out = []
    for path, obj in exported():
        if inspect.isfunction(obj):
            out.append(path)
            continue
        for name, member in vars(obj).items():
            func = member.__func__ if isinstance(member, (staticmethod, classmethod)) else member
            if not name.startswith("_") and inspect.isfunction(func):
                out.append(f"{path}.{name}")
    return out


def public_dataclasses() -> list[str]:
    return [path for path, obj in exported() if inspect.isclass(obj) and dataclasses.is_dataclass(obj)]


def public_classes() -> list[str]:
    return [path for path, obj in exported() if inspect.isclass(obj)]


CALLABLES = public_callables()
CLASSES = public_classes()
DATACLASSES = public_dataclasses()


def test_the_walk_finds_the_public_api():
    """The walk sees every module's exports, methods of classes included, not only the top level."""
    assert len(CALLABLES) > 450
    assert "auv_hinf.numerics.bisection.bisect" in CALLABLES
    assert "auv_hinf.models.jacobi.JacobiTransform.to_jacobi" in CALLABLES  # a method
    assert "auv_hinf.models.vehicle.PlantBatch.from_params" in CALLABLES  # a class method
    assert "auv_hinf.mission.paths.MissionBounds.widened" in CALLABLES  # a static method
    assert "auv_hinf.closed_loop.region.RegionCertificate" in DATACLASSES
    assert len(DATACLASSES) > 80


@pytest.mark.slow
@pytest.mark.parametrize("path", CALLABLES)
def test_callable_numpydoc(path):
    """Every public function and method documents each parameter (PR01) and passes the class checks."""
    result = validate(path)
    errors = [f"{code}: {msg}" for code, msg in result["errors"] if code in CALLABLE_CHECKS]
    assert not errors, f"{path}: " + "; ".join(errors)


@pytest.mark.slow
@pytest.mark.parametrize("path", CLASSES)
def test_class_numpydoc(path):
    """Every public class of every module passes the checks (PR01 aside: see NUMPYDOC_CHECKS)."""
    result = validate(path)
    errors = [f"{code}: {msg}" for code, msg in result["errors"] if code in NUMPYDOC_CHECKS]
    assert not errors, f"{path}: " + "; ".join(errors)


def documented_names(doc: str | None) -> set[str]:
    """Names in the Attributes and Parameters sections (``a, b : float`` names both)."""
    parsed = NumpyDocString(doc or "")
    return {
        part.strip().lstrip("*")
        for section in ("Attributes", "Parameters")
        for entry in parsed[section]
        for part in entry.name.split(",")
    }


def test_documented_names_parser():
    doc = "Summary.\n\nAttributes\n----------\na, b : float\n    Two.\nc : int\n    One.\n"
    assert documented_names(doc) == {"a", "b", "c"}
    assert documented_names("Summary.") == set()


@pytest.mark.parametrize("path", DATACLASSES)
def test_dataclass_fields_documented(path):
    """Every public field of a public dataclass, inherited ones included, is in its Attributes or Parameters."""
    module, name = path.rsplit(".", 1)
    cls = getattr(importlib.import_module(module), name)
    names = documented_names(inspect.getdoc(cls))
    missing = [f.name for f in dataclasses.fields(cls) if f.name not in names and not f.name.startswith("_")]
    assert not missing, f"{path}: fields not under Attributes or Parameters: {missing}"


def doc_pages() -> list[Path]:
    return sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts and p.parent.name != "notebooks")


def test_docs_pages_exist():
    names = {p.relative_to(DOCS).as_posix() for p in doc_pages()}
    for page in (
        "index.md",
        "errata.md",
        "equations.md",
        "derivations/theorem1.md",
        "derivations/sigma.md",
        "derivations/closed_loop.md",
    ):
        assert page in names


TEST_REF = re.compile(r"(tests/(?:\w+/)*test_\w+\.py)::(\w+)")
#: A test file named anywhere on a page, with or without a test after it.
TEST_FILE = re.compile(r"\btests/(?:\w+/)*test_\w+\.py\b")
#: Generated from auv_hinf.config.reference_doc (tests/config/test_config_reference.py keeps
#: it in step): its wording, test paths included, lives in the package, not in the page.
GENERATED_PAGES = frozenset({"config.md"})


def test_referenced_tests_exist():
    refs = {(f, t) for page in doc_pages() for f, t in TEST_REF.findall(page.read_text(encoding="utf-8"))}
    assert len(refs) >= 15, "the errata and derivation pages cite their tests"
    missing = []
    for file, test in sorted(refs):
        path = ROOT / file
        if not path.exists() or not re.search(rf"^def {test}\(", path.read_text(encoding="utf-8"), re.M):
            missing.append(f"{file}::{test}")
    assert not missing, f"docs cite tests that do not exist: {missing}"


def test_referenced_test_files_exist():
    """Every test file a hand-written page or the README names is where it says (tests/<subpackage>/...)."""
    pages = [p for p in doc_pages() if p.relative_to(DOCS).as_posix() not in GENERATED_PAGES]
    refs = {f for page in [*pages, ROOT / "README.md"] for f in TEST_FILE.findall(page.read_text(encoding="utf-8"))}
    assert len(refs) >= 10, "the derivation pages and the errata name their test files"
    missing = sorted(f for f in refs if not (ROOT / f).is_file())
    assert not missing, f"docs name test files that do not exist: {missing}"


def test_docs_speak_for_themselves():
    """The pages refer to the project's own files and pages only."""
    for page in [*doc_pages(), DOCS / "conf.py"]:
        text = page.read_text(encoding="utf-8")
        assert "PAPER-NOTES" not in text and "../shared" not in text, page


EQ_REF = re.compile(r"\b(?:eqs?\.|equations?)\s*\(?(\d+)\)?(?:\s*-\s*\(?(\d+)\)?)?", re.I)


def equation_numbers(text: str) -> set[int]:
    out: set[int] = set()
    for lo, hi in EQ_REF.findall(text):
        out.update(range(int(lo), int(hi or lo) + 1))
    return out


def test_every_cited_equation_is_on_the_equation_map():
    cited = set()
    for path in PACKAGE.rglob("*.py"):
        cited |= equation_numbers(path.read_text(encoding="utf-8"))
    assert {8, 32, 37} <= cited
    mapped = set()
    for row in (DOCS / "equations.md").read_text(encoding="utf-8").splitlines():
        if row.startswith("| eq"):
            first_cell = row.split("|")[1]
            for lo, hi in re.findall(r"\((\d+)\)(?:-\((\d+)\))?", first_cell):
                mapped.update(range(int(lo), int(hi or lo) + 1))
    missing = sorted(cited - mapped)
    assert not missing, f"equations cited in the package but not on docs/equations.md: {missing}"
