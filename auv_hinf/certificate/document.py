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
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Protocol, TypeVar, cast

import numpy as np

from auv_hinf._version import __version__
from auv_hinf.actuation import limits as actuators
from auv_hinf.actuation import thrust
from auv_hinf.certificate.parts import actuators as actuator_check
from auv_hinf.certificate.parts import closed_loop as nominal
from auv_hinf.certificate.parts import implementation as implementation_part
from auv_hinf.certificate.parts import robust as robust_part
from auv_hinf.closed_loop import coverage, region
from auv_hinf.closed_loop import nominal as closed_loop
from auv_hinf.config.settings import FormationConfig, config_from_dict
from auv_hinf.design import crosscheck, sigma, theorem1
from auv_hinf.design import theorem1 as alpha
from auv_hinf.exceptions import AuvHinfError, ConfigError
from auv_hinf.implementation import lag as lag_terms
from auv_hinf.implementation import lmi as sampled
from auv_hinf.implementation import model as implementation_model
from auv_hinf.implementation import sampled_data as implementation
from auv_hinf.law import gains
from auv_hinf.law.gains import Gains, heading_gains
from auv_hinf.mission import fit as reference_fit
from auv_hinf.mission import fleet as motion
from auv_hinf.mission import fleet as path_frame
from auv_hinf.mission import fleet as reference
from auv_hinf.mission import fleet as shaping
from auv_hinf.mission import margins, paths
from auv_hinf.mission import paths as lawnmower
from auv_hinf.models import envelope, vehicle
from auv_hinf.robust import bandwidth, box, margin
from auv_hinf.robust import invariant_set as certificate
from auv_hinf.robust import invariant_set as ellipsoid

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


#: Value of the ``format`` key of a certificate file.
FORMAT = "auv-hinf-certificate"


#: Layout version written by this module.
VERSION = 3


#: Layout versions :func:`certificate_from_document` reads (1: auv-hinf 0.2.0).
READABLE_VERSIONS = (1, 2, 3)


class StoredCertificate(Protocol):
    """What this module needs of a certificate: a dataclass with a configuration and a record."""

    @property
    def config(self) -> FormationConfig:
        """The certified configuration."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The readable record (the ``auv-hinf certify --json`` layout)."""
        ...


C = TypeVar("C", bound=StoredCertificate)


def certificate_document(cert: StoredCertificate, created: datetime | None = None) -> dict[str, Any]:
    """The JSON document of ``cert`` (see the module docstring).

    Parameters
    ----------
    cert : Certificate
    created : datetime, optional
        Time stamp (default: now, UTC).
    """

    stamp = (created or datetime.now(timezone.utc)).astimezone(timezone.utc)
    state = {
        f.name: encode_value(getattr(cert, f.name)) for f in dataclasses.fields(cast(Any, cert)) if f.name != "config"
    }
    return {
        "format": FORMAT,
        "version": VERSION,
        "tool_version": __version__,
        "created": stamp.isoformat(),
        "config": cert.config.to_toml_dict(),
        "certificate": json_normal(cert.to_dict()),
        "state": state,
    }


def certificate_from_document(doc: Any, cls: type[C], source: str = "certificate") -> C:
    """Rebuild the :class:`~auv_hinf.certificate.assembly.Certificate` of a document of :func:`certificate_document`.

    Parameters
    ----------
    doc : dict
        The parsed JSON document.
    cls : type
        The certificate class to build.
    source : str
        Name used in error messages (e.g. the file name).

    Raises
    ------
    ConfigError
        If the format or version differs, a key is missing, the configuration is invalid,
        a stored value cannot be rebuilt, or the readable record disagrees with the state.
    """
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        found = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise ConfigError(f"{source}: not an auv-hinf certificate file (format {found!r}, expected {FORMAT!r})")
    version = doc.get("version")
    if isinstance(version, bool) or version not in READABLE_VERSIONS:
        raise ConfigError(
            f"{source}: unsupported certificate version {version!r} (this auv-hinf reads "
            f"versions {list(READABLE_VERSIONS)}; it was written by auv-hinf {doc.get('tool_version')!r})"
        )
    missing = [k for k in ("config", "certificate", "state") if not isinstance(doc.get(k), dict)]
    if missing:
        raise ConfigError(f"{source}: certificate file lacks the object(s) {missing}")
    try:
        config = config_from_dict(doc["config"])
    except ConfigError as exc:
        raise ConfigError("\n".join(f"{source}: config: {line}" for line in str(exc).splitlines())) from None
    state = doc["state"]
    names = [f.name for f in dataclasses.fields(cast(Any, cls)) if f.name != "config"]
    names = [n for n in names if n not in _added_after(version)]
    absent = [n for n in names if n not in state]
    extra = sorted(set(state) - set(names))
    if absent or extra:
        raise ConfigError(
            f"{source}: certificate state does not match this version (missing {absent}, unknown {extra})"
        )
    try:
        values = {n: decode_value(state[n]) for n in names}
        if version == 1:
            values.update(_gains_of_version_1(config, values))
        cert: C = cast(Any, cls)(config=config, **values)
        record = json_normal(cert.to_dict())
        if version < VERSION:  # compare on the keys the older record has
            record = {k: record.get(k) for k in doc["certificate"]}
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        raise ConfigError(f"{source}: cannot rebuild the certificate: {exc}") from None
    if record != doc["certificate"]:
        diff = sorted(k for k in set(record) | set(doc["certificate"]) if record.get(k) != doc["certificate"].get(k))
        raise ConfigError(f"{source}: the certificate record disagrees with its stored state in {diff} (edited file?)")
    return cert


#: Certificate fields that version 1 files lack.
_ADDED_IN_2 = ("gains", "gain_source", "actuators", "design")


#: Certificate fields that version 2 files lack (the implementation certificate).
_ADDED_IN_3 = ("implementation",)


def _added_after(version: int) -> tuple[str, ...]:
    """Certificate fields a file of ``version`` lacks (they keep their defaults)."""
    return (_ADDED_IN_2 if version < 2 else ()) + (_ADDED_IN_3 if version < 3 else ())


def _gains_of_version_1(config: FormationConfig, values: dict[str, Any]) -> dict[str, Any]:
    """The gains that ran for a version 1 certificate: the robust design's, or the Theorem 1 gains."""
    if config.robust:
        rob = values.get("robust")
        g = None if rob is None else rob.gains
        return {"gains": g, "gain_source": "robust"}
    alpha_used = values.get("alpha_used")
    if alpha_used is None:
        return {"gains": None, "gain_source": "theorem1"}
    return {
        "gains": Gains(alpha_used, config.k1, heading_gains(config.vehicle, config.heading_poles)),
        "gain_source": "theorem1",
    }


def save_certificate(cert: StoredCertificate, path: str | Path, *, created: datetime | None = None) -> Path:
    """Write ``cert`` as a versioned JSON file (strict JSON, UTF-8, 2-space indent).

    Parameters
    ----------
    cert : Certificate
    path : str or Path
        The file to write; its parent directory must exist.
    created : datetime, optional
        Time stamp (default: now, UTC).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ConfigError
        If the file cannot be written or the certificate holds a value that cannot be stored.
    """
    p = Path(path)
    text = json.dumps(certificate_document(cert, created), indent=2, allow_nan=False) + "\n"
    try:
        p.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot write certificate {str(p)!r}: {exc.strerror}") from None
    return p


def load_certificate(path: str | Path, cls: type[C]) -> C:
    """Read a file written by :func:`save_certificate` and rebuild the certificate exactly.

    Raises
    ------
    ConfigError
        If the file cannot be read or is not JSON, or for any reason of
        :func:`certificate_from_document`; messages start with the file name.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise ConfigError(f"cannot read certificate {str(p)!r}: {reason}") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{p}: invalid JSON: {exc}") from None
    return certificate_from_document(doc, cls, source=str(p))


__all__ = [
    "ARRAY_KINDS",
    "FORMAT",
    "LEGACY_NAMES",
    "READABLE_VERSIONS",
    "STORED_TYPES",
    "VERSION",
    "C",
    "StoredCertificate",
    "certificate_document",
    "certificate_from_document",
    "decode_value",
    "encode_value",
    "json_normal",
    "json_safe",
    "load_certificate",
    "save_certificate",
]
