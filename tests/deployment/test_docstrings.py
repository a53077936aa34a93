"""Every public function and method of the deployment package documents every parameter (numpydoc PR01 too)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest
from numpydoc.validate import validate

import auv_hinf.deployment
from tests.project.test_docs import NUMPYDOC_CHECKS

#: The project's checks, and PR01 (a parameter without an entry) for functions and methods; classes
#: document their fields under "Attributes" (or "Parameters") and are held to the project's set.
CHECKS = NUMPYDOC_CHECKS | {"PR01"}
MODULES = [
    f"auv_hinf.deployment.{m.name}"
    for m in pkgutil.iter_modules(auv_hinf.deployment.__path__)
    if not m.name.startswith("_")
]


def _objects() -> list[tuple[str, bool]]:
    """``(dotted name, is a class)`` of every public function, class and public method defined in the package."""
    out = []
    for name in MODULES:
        module = importlib.import_module(name)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if getattr(obj, "__module__", None) != name:
                continue
            if inspect.isfunction(obj):
                out.append((f"{name}.{attr}", False))
            elif inspect.isclass(obj):
                out.append((f"{name}.{attr}", True))
                for meth, member in vars(obj).items():
                    fn = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
                    if not meth.startswith("_") and inspect.isfunction(fn):
                        out.append((f"{name}.{attr}.{meth}", False))
    return out


@pytest.mark.parametrize(("name", "is_class"), _objects())
def test_numpydoc_with_every_parameter(name: str, is_class: bool) -> None:
    checks = NUMPYDOC_CHECKS if is_class else CHECKS
    errors = [f"{code}: {msg}" for code, msg in validate(name)["errors"] if code in checks]
    assert not errors, f"{name}: " + "; ".join(errors)


def test_the_walk_sees_the_package() -> None:
    names = {n for n, _ in _objects()}
    assert "auv_hinf.deployment.runtime.RuntimeLaw.step" in names and len(names) > 60
