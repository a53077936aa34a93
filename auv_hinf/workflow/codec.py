"""Tagged JSON values: the exact, type-keeping encoding of a certificate's state.

:func:`encode_value` turns a value into strict JSON that :func:`decode_value` inverts
exactly: floats (written with ``repr``, which round-trips every IEEE double), numpy arrays
(dtype and shape), tuples, dictionaries and the package's frozen dataclasses (by a stable
type name from :data:`STORED_TYPES`, rebuilt through their constructors). Type names do not
change when a class moves between modules. :func:`json_safe` is the CLI's rule for plain
JSON output (non-finite numbers as ``null``).

Tagged forms (any other JSON value stands for itself; lists are lists)::

    {"$float": "inf" | "-inf" | "nan"}
    {"$complex": [re, im]}
    {"$numpy": "<dtype>", "value": v}                        numpy scalar
    {"$ndarray": "<dtype>", "shape": [...], "data": [...]}   flat data, C order
    {"$tuple": [...]}
    {"$dict": {...}}                                          string keys only
    {"$dataclass": "<type name>", "fields": {...}}            init fields only

Version 1 certificate files (auv-hinf 0.2.0) named classes ``"auv_hinf.module:Class"``; such
names are looked up by their class name (with :data:`LEGACY_NAMES` for renamed types).
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

from auv_hinf.certification import (
    closed_loop,
    coverage,
    implementation,
    lag_terms,
    margins,
    reference_fit,
    region,
    thrust,
)
from auv_hinf.design import alpha, crosscheck, gains, sigma, theorem1
from auv_hinf.design.lmi import ellipsoid, sampled
from auv_hinf.exceptions import AuvHinfError, ConfigError
from auv_hinf.models import actuators, envelope, lawnmower, motion, path_frame, paths, reference, shaping, vehicle
from auv_hinf.models import implementation as implementation_model
from auv_hinf.robust import bandwidth, box, certificate, margin
from auv_hinf.workflow import actuator_check, implementation_part, nominal, robust_part

#: Modules whose dataclasses may appear in a certificate's state.
_STORED_MODULES = (
    actuator_check,
    actuators,
    alpha,
    bandwidth,
    box,
    certificate,
    closed_loop,
    coverage,
    crosscheck,
    ellipsoid,
    envelope,
    gains,
    implementation,
    implementation_model,
    implementation_part,
    lag_terms,
    lawnmower,
    margin,
    margins,
    motion,
    nominal,
    path_frame,
    paths,
    reference,
    reference_fit,
    region,
    robust_part,
    sampled,
    shaping,
    sigma,
    theorem1,
    thrust,
    vehicle,
)


def _registry() -> dict[str, type]:
    """Stable type name (the class name) -> dataclass, for every dataclass of :data:`_STORED_MODULES`."""
    out: dict[str, type] = {}
    for mod in _STORED_MODULES:
        for obj in vars(mod).values():
            if isinstance(obj, type) and dataclasses.is_dataclass(obj) and obj.__module__ == mod.__name__:
                if out.get(obj.__name__, obj) is not obj:  # pragma: no cover - guarded by a test
                    raise RuntimeError(f"two stored dataclasses are called {obj.__name__}")
                out[obj.__name__] = obj
    return out


#: The types a certificate file may hold, by stable name.
STORED_TYPES: dict[str, type] = _registry()
#: Version 1 class names that were renamed: old name -> stable name.
LEGACY_NAMES = {"RobustGains": "Gains"}
#: numpy dtype kinds that may be stored: bool, signed and unsigned int, float, complex.
ARRAY_KINDS = "biufc"


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by ``None`` and tuples by lists (the CLI's JSON rule)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def json_normal(obj: Any) -> Any:
    """``obj`` as it reads back from a JSON file: :func:`json_safe`, then a dump/parse round trip."""
    return json.loads(json.dumps(json_safe(obj), allow_nan=False))


def encode_value(obj: Any) -> Any:
    """Tagged, strict-JSON form of ``obj`` that :func:`decode_value` inverts exactly.

    Raises
    ------
    ConfigError
        If ``obj`` holds a value of a type that cannot be stored (e.g. an object array, a
        dictionary with non-string keys, or an object that is not a dataclass of this package).
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.generic):
        if obj.dtype.kind not in ARRAY_KINDS:
            raise ConfigError(f"cannot store a numpy scalar of dtype {obj.dtype}")
        return {"$numpy": obj.dtype.str, "value": encode_value(obj.item())}
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else {"$float": repr(float(obj))}
    if isinstance(obj, complex):
        return {"$complex": [encode_value(obj.real), encode_value(obj.imag)]}
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in ARRAY_KINDS:
            raise ConfigError(f"cannot store a numpy array of dtype {obj.dtype}")
        return {
            "$ndarray": obj.dtype.str,
            "shape": list(obj.shape),
            "data": [encode_value(x) for x in obj.ravel().tolist()],
        }
    if isinstance(obj, tuple):
        return {"$tuple": [encode_value(x) for x in obj]}
    if isinstance(obj, list):
        return [encode_value(x) for x in obj]
    if isinstance(obj, dict):
        if not all(isinstance(k, str) for k in obj):
            raise ConfigError(f"cannot store a dictionary with non-string keys: {list(obj)!r}")
        return {"$dict": {k: encode_value(v) for k, v in obj.items()}}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        cls = type(obj)
        if STORED_TYPES.get(cls.__name__) is not cls:
            raise ConfigError(f"cannot store an instance of {cls.__module__}.{cls.__qualname__}")
        return {
            "$dataclass": cls.__name__,
            "fields": {f.name: encode_value(getattr(obj, f.name)) for f in dataclasses.fields(obj) if f.init},
        }
    raise ConfigError(f"cannot store a value of type {type(obj).__name__}: {obj!r}")


def decode_value(data: Any) -> Any:
    """Inverse of :func:`encode_value`.

    Raises
    ------
    ConfigError
        On an unknown tag, a class outside the package, or a value its constructor refuses.
    """
    if data is None or isinstance(data, (bool, str, int, float)):
        return data
    if isinstance(data, list):
        return [decode_value(x) for x in data]
    if not isinstance(data, dict):
        raise ConfigError(f"unexpected value in a certificate file: {data!r}")
    keys = set(data)
    if keys == {"$float"} and data["$float"] in ("inf", "-inf", "nan"):
        return float(data["$float"])
    if keys == {"$complex"} and isinstance(data["$complex"], list) and len(data["$complex"]) == 2:
        re_, im_ = (decode_value(x) for x in data["$complex"])
        return complex(re_, im_)
    if keys == {"$numpy", "value"}:
        dtype = _dtype(data["$numpy"])
        return dtype.type(decode_value(data["value"]))
    if keys == {"$ndarray", "shape", "data"}:
        dtype = _dtype(data["$ndarray"])
        shape = data["shape"]
        if not (isinstance(shape, list) and all(isinstance(s, int) and s >= 0 for s in shape)):
            raise ConfigError(f"bad array shape in a certificate file: {shape!r}")
        values = decode_value(data["data"])
        if not isinstance(values, list) or len(values) != math.prod(shape):
            raise ConfigError(f"array data of a certificate file do not fill shape {shape}")
        return np.array(values, dtype=dtype).reshape(shape)
    if keys == {"$tuple"} and isinstance(data["$tuple"], list):
        return tuple(decode_value(x) for x in data["$tuple"])
    if keys == {"$dict"} and isinstance(data["$dict"], dict):
        return {k: decode_value(v) for k, v in data["$dict"].items()}
    if keys == {"$dataclass", "fields"} and isinstance(data["fields"], dict):
        cls = _dataclass(data["$dataclass"])
        kwargs = {k: decode_value(v) for k, v in data["fields"].items()}
        try:
            return cls(**kwargs)
        except (TypeError, ValueError, AuvHinfError) as exc:
            raise ConfigError(f"cannot rebuild {data['$dataclass']} from a certificate file: {exc}") from None
    raise ConfigError(f"unknown tagged value in a certificate file (keys {sorted(keys)})")


def _dtype(text: Any) -> np.dtype[Any]:
    try:
        dtype = np.dtype(text) if isinstance(text, str) else None
    except TypeError:
        dtype = None
    if dtype is None or dtype.kind not in ARRAY_KINDS:
        raise ConfigError(f"bad numpy dtype in a certificate file: {text!r}")
    return dtype


def _dataclass(ref: Any) -> type:
    """The stored dataclass named ``ref``: a stable type name, or a version 1 ``"module:Class"``."""
    if not isinstance(ref, str):
        raise ConfigError(f"bad class reference in a certificate file: {ref!r}")
    name = ref
    if ":" in ref:  # version 1: "auv_hinf.module:QualName"
        module, _, name = ref.partition(":")
        if not (module == "auv_hinf" or module.startswith("auv_hinf.")):
            raise ConfigError(f"refusing to rebuild class {ref!r}: not part of auv_hinf")
        name = LEGACY_NAMES.get(name, name)
    cls = STORED_TYPES.get(name)
    if cls is None:
        raise ConfigError(f"class {ref!r} of a certificate file does not exist in this version")
    return cls


__all__ = [
    "ARRAY_KINDS",
    "LEGACY_NAMES",
    "STORED_TYPES",
    "decode_value",
    "encode_value",
    "json_normal",
    "json_safe",
]
