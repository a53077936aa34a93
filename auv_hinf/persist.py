"""Versioned, complete certificate files: save a :class:`~auv_hinf.certificate.Certificate`
as JSON and load it back exactly.

A certificate file is one JSON object::

    {
      "format": "auv-hinf-certificate",
      "version": 1,
      "tool_version": "<auv_hinf.__version__ that wrote it>",
      "created": "<ISO 8601 time stamp, UTC>",
      "config": {... FormationConfig.to_toml_dict() ...},
      "certificate": {... Certificate.to_dict(), the ``auv-hinf certify --json`` layout ...},
      "state": {... every other field of the Certificate, exactly ...}
    }

``config`` makes the file complete: vehicle, shape, envelope, design, heading poles,
reference, simulation, uncertainty and disturbance settings (``config_from_dict`` rebuilds
the :class:`~auv_hinf.config.FormationConfig`). ``certificate`` is the readable record
(non-finite numbers written as ``null``, as the CLI does). ``state`` restores every other
field *exactly*, without re-running :func:`~auv_hinf.certificate.certify`: each value is
stored in a tagged form that keeps its type, so floats (written with ``repr``, which
round-trips every IEEE double), numpy arrays (dtype and shape), tuples, dictionaries and the
package's frozen dataclasses (by module and class name, rebuilt through their constructors)
come back as they were. Loading checks the format and version, and that the readable record
equals the ``to_dict()`` of the rebuilt certificate, so an edited or truncated file is
refused with a :class:`~auv_hinf.exceptions.ConfigError` rather than silently believed.

Tagged forms in ``state`` (any other JSON value stands for itself; lists are lists)::

    {"$float": "inf" | "-inf" | "nan"}
    {"$complex": [re, im]}
    {"$numpy": "<dtype>", "value": v}                        numpy scalar
    {"$ndarray": "<dtype>", "shape": [...], "data": [...]}   flat data, C order
    {"$tuple": [...]}
    {"$dict": {...}}                                          string keys only
    {"$dataclass": "auv_hinf.module:Class", "fields": {...}}  init fields only
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import math
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .config import config_from_dict
from .exceptions import AuvHinfError, ConfigError

if TYPE_CHECKING:
    from .certificate import Certificate

#: Value of the ``format`` key of a certificate file.
FORMAT = "auv-hinf-certificate"
#: Layout version written by this module; :func:`load_certificate` reads exactly this one.
VERSION = 1
#: Dataclasses are restored only from modules of this package.
PACKAGE = "auv_hinf"
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
        if not _in_package(cls.__module__):
            raise ConfigError(f"cannot store an instance of {cls.__module__}.{cls.__qualname__}")
        return {
            "$dataclass": f"{cls.__module__}:{cls.__qualname__}",
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


def _in_package(module: str) -> bool:
    return module == PACKAGE or module.startswith(PACKAGE + ".")


def _dtype(text: Any) -> np.dtype[Any]:
    try:
        dtype = np.dtype(text) if isinstance(text, str) else None
    except TypeError:
        dtype = None
    if dtype is None or dtype.kind not in ARRAY_KINDS:
        raise ConfigError(f"bad numpy dtype in a certificate file: {text!r}")
    return dtype


def _dataclass(ref: Any) -> type:
    """The dataclass named ``"module:QualName"`` (only inside this package)."""
    if not isinstance(ref, str) or ref.count(":") != 1:
        raise ConfigError(f"bad class reference in a certificate file: {ref!r}")
    module, qualname = ref.split(":")
    if not _in_package(module):
        raise ConfigError(f"refusing to rebuild class {ref!r}: not part of {PACKAGE}")
    try:
        obj: Any = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError):
        obj = _moved_dataclass(qualname)
        if obj is None:
            raise ConfigError(f"class {ref!r} of a certificate file does not exist in this version") from None
    if not (isinstance(obj, type) and dataclasses.is_dataclass(obj)):
        raise ConfigError(f"{ref!r} in a certificate file is not a dataclass")
    return obj


def _moved_dataclass(qualname: str) -> type | None:
    """The one dataclass of the package called ``qualname`` (a class moved between modules), or None."""
    import pkgutil

    pkg = importlib.import_module(PACKAGE)
    found: set[type] = set()
    for info in pkgutil.walk_packages(pkg.__path__, PACKAGE + "."):
        try:
            mod = importlib.import_module(info.name)
        except ImportError:  # pragma: no cover - optional dependency of an unrelated module
            continue
        obj = getattr(mod, qualname, None)
        if isinstance(obj, type) and dataclasses.is_dataclass(obj) and _in_package(obj.__module__):
            found.add(obj)
    return found.pop() if len(found) == 1 else None


def certificate_document(cert: Certificate, created: datetime | None = None) -> dict[str, Any]:
    """The JSON document of ``cert`` (see the module docstring).

    Parameters
    ----------
    cert : Certificate
    created : datetime, optional
        Time stamp (default: now, UTC).
    """
    from . import __version__

    stamp = (created or datetime.now(timezone.utc)).astimezone(timezone.utc)
    state = {f.name: encode_value(getattr(cert, f.name)) for f in dataclasses.fields(cert) if f.name != "config"}
    return {
        "format": FORMAT,
        "version": VERSION,
        "tool_version": __version__,
        "created": stamp.isoformat(),
        "config": cert.config.to_toml_dict(),
        "certificate": json_normal(cert.to_dict()),
        "state": state,
    }


def certificate_from_document(doc: Any, source: str = "certificate") -> Certificate:
    """Rebuild the :class:`~auv_hinf.certificate.Certificate` of a document of :func:`certificate_document`.

    Parameters
    ----------
    doc : dict
        The parsed JSON document.
    source : str
        Name used in error messages (e.g. the file name).

    Raises
    ------
    ConfigError
        If the format or version differs, a key is missing, the configuration is invalid,
        a stored value cannot be rebuilt, or the readable record disagrees with the state.
    """
    from .certificate import Certificate

    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        found = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise ConfigError(f"{source}: not an auv-hinf certificate file (format {found!r}, expected {FORMAT!r})")
    version = doc.get("version")
    if isinstance(version, bool) or version != VERSION:
        raise ConfigError(
            f"{source}: unsupported certificate version {version!r} (this auv-hinf reads "
            f"version {VERSION}; it was written by auv-hinf {doc.get('tool_version')!r})"
        )
    missing = [k for k in ("config", "certificate", "state") if not isinstance(doc.get(k), dict)]
    if missing:
        raise ConfigError(f"{source}: certificate file lacks the object(s) {missing}")
    try:
        config = config_from_dict(doc["config"])
    except ConfigError as exc:
        raise ConfigError("\n".join(f"{source}: config: {line}" for line in str(exc).splitlines())) from None
    state = doc["state"]
    names = [f.name for f in dataclasses.fields(Certificate) if f.name != "config"]
    absent = [n for n in names if n not in state]
    extra = sorted(set(state) - set(names))
    if absent or extra:
        raise ConfigError(
            f"{source}: certificate state does not match this version (missing {absent}, unknown {extra})"
        )
    try:
        values = {n: decode_value(state[n]) for n in names}
        cert = Certificate(config=config, **values)
        record = json_normal(cert.to_dict())
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        raise ConfigError(f"{source}: cannot rebuild the certificate: {exc}") from None
    if record != doc["certificate"]:
        diff = sorted(k for k in set(record) | set(doc["certificate"]) if record.get(k) != doc["certificate"].get(k))
        raise ConfigError(f"{source}: the certificate record disagrees with its stored state in {diff} (edited file?)")
    return cert


def save_certificate(cert: Certificate, path: str | Path, *, created: datetime | None = None) -> Path:
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


def load_certificate(path: str | Path) -> Certificate:
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
    return certificate_from_document(doc, source=str(p))


__all__ = [
    "FORMAT",
    "VERSION",
    "certificate_document",
    "certificate_from_document",
    "decode_value",
    "encode_value",
    "json_normal",
    "json_safe",
    "load_certificate",
    "save_certificate",
]
