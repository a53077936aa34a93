"""Docstrings and documentation pages stay consistent with the code.

* every public function and class passes a chosen set of numpydoc checks;
* every test named in docs/ exists;
* every paper equation the package cites is on the equation map.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest
from numpydoc.validate import validate

import auv_hinf

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PACKAGE = ROOT / "auv_hinf"

#: numpydoc checks every public object must pass. Left out on purpose: ES01 (extended
#: summary), EX01 (examples), SA01 (see also), RT01 (returns section: one-line
#: docstrings of small functions state the result), PR01 (dataclasses document their
#: fields under "Attributes"). PR03, PR04, PR07 and SS05 are not enforced yet either.
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


@pytest.mark.parametrize("name", public_objects())
def test_numpydoc(name):
    obj = getattr(auv_hinf, name)
    result = validate(f"{obj.__module__}.{obj.__qualname__}")
    errors = [f"{code}: {msg}" for code, msg in result["errors"] if code in NUMPYDOC_CHECKS]
    assert not errors, f"{name}: " + "; ".join(errors)


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
