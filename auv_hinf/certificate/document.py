"""The stored certificate: its documented JSON layout, its JSON Schema, and the files of every version.

A certificate file is one JSON object (format version 4)::

    {
      "format": "auv-hinf-certificate",
      "version": 4,
      "tool_version": "<auv_hinf.__version__ that wrote it>",
      "created": "<ISO 8601 time stamp, UTC>",
      "config": {... FormationConfig.to_toml_dict() ...},
      "certificate": {... Certificate.to_dict(): the ``auv-hinf certify --json`` layout ...},
      "digest": "sha256:<hex>"
    }

``config`` makes the file complete (``config_from_dict`` rebuilds the configuration);
``certificate`` is exactly what ``certify --json`` prints, with every part's figures under its
key and every part's verdict and reasons, as data, under ``parts``. The file holds no Python
class names: it is read back by :class:`CertificateDocument`, whose JSON Schema
(:func:`certificate_schema`, printed by ``auv-hinf schema --certificate`` and published as
``docs/certificate.schema.json``) is the contract. ``digest`` is the SHA-256 of the canonical
JSON of ``config`` and ``certificate``: a file edited by hand, or truncated, is refused rather
than believed; so is one whose record disagrees with its configuration, or whose verdict
disagrees with its parts.

Loading (:meth:`~auv_hinf.certificate.assembly.Certificate.load`) gives a certificate with every part's figures,
verdict and reasons, the configuration and the gains that ran (so :meth:`law` and
:meth:`controller` work), and the same text as the certificate that was saved. The parts'
typed results (LMI matrices) are not stored; ``certify`` recomputes them.

Versions 1-3 (auv-hinf 0.2-0.4) stored a tagged copy of every Python object beside the record.
They still load: the record is read and the tagged copy is ignored, except for version 1, whose
record does not list the gains that ran (they are the robust design's recorded gains with
``[design] robust = true``, else the configured Theorem 1 gains). Their verdict is the recorded
one, under one part called ``recorded``.
"""

from __future__ import annotations

import hashlib
import json
import math
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Literal, Protocol, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from auv_hinf._version import __version__
from auv_hinf.certificate.reason import REASON_KINDS, ReasonKind
from auv_hinf.config.settings import FormationConfig, config_from_dict, read_document
from auv_hinf.exceptions import ConfigError
from auv_hinf.law.gains import GainSource, heading_gains

#: Value of the ``format`` key of a certificate file.
FORMAT = "auv-hinf-certificate"
#: Layout version written by this module.
VERSION = 4
#: Layout versions :func:`load_certificate` reads (1: auv-hinf 0.2.0; 2-3: the tagged-state files).
READABLE_VERSIONS = (1, 2, 3, 4)
#: The top-level keys of the Theorem 1 part in records of versions 1-3 (the figures it owns).
LEGACY_THEOREM1_KEYS = (
    "lambda",
    "sigma",
    "sigma_jacobi",
    "certificate_coords",
    "gamma",
    "method",
    "alpha",
    "paper_flags",
    "theorem1",
    "small_gain_margin",
    "k1",
    "position_loop_hinf",
    "crosscheck_ok",
    "crosscheck_n",
    "crosscheck_max_rel_diff",
)
#: The parts with a key of their own in records of versions 1-3.
LEGACY_PART_KEYS = ("closed_loop", "robust", "actuators", "implementation")


class StoredCertificate(Protocol):
    """What a certificate file stores of a certificate: its configuration and its record."""

    @property
    def config(self) -> FormationConfig:
        """The certified configuration."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The record (the ``certify --json`` layout)."""
        ...


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SettingRecord(_Strict):
    """A configuration value that would change a verdict."""

    table: str = Field(description="TOML table")
    key: str = Field(description="key in that table")
    value: Any = Field(description="the value to write there, in the key's unit")
    unit: str = Field("", description="the key's unit (empty: dimensionless)")


class ReasonRecord(_Strict):
    """A reason, as data."""

    part: str
    kind: ReasonKind = Field(description=f"one of {', '.join(REASON_KINDS)}")
    message: str
    channel: str | None = None
    vehicle: int | None = None
    value: float | None = None
    limit: float | None = None
    settings: list[SettingRecord] = Field(default_factory=list)


class PartRecord(_Strict):
    """One part's verdict: does it hold, does it apply, why not, and where its figures are."""

    ok: bool
    applies: bool
    reasons: list[ReasonRecord]
    key: str | None = Field(description="the record's key holding the part's figures (null: top-level keys)")
    keys: list[str] | None = Field(default=None, description="the top-level keys of a part without a key")
    note: str | None = None


class GainsRecord(_Strict):
    """The gains that run."""

    alpha: float = Field(description="velocity gain (1/s)")
    k1: float = Field(description="position gain (1/s^2)")
    k_psi: list[float] = Field(min_length=2, max_length=2, description="heading gains (1/s^2, 1/s)")
    ki: float | None = Field(default=None, description="integral gain (1/s^3), with integral action")
    source: GainSource


class CertificateRecord(BaseModel):
    """The ``certify --json`` layout: the keys every record has, and the parts' figures beside them."""

    model_config = ConfigDict(extra="allow", frozen=True)

    preset: str = Field(description="the configuration's name")
    n: int = Field(ge=2, description="fleet size")
    certified: bool = Field(description="every part holds")
    reasons: list[str] = Field(description="why not, one sentence per reason")
    envelope: dict[str, Any]
    vehicle: dict[str, Any]
    gains: GainsRecord | None
    design: dict[str, Any] | None
    parts: dict[str, PartRecord] = Field(description="each part's verdict, by part name, in evaluation order")


class CertificateDocument(_Strict):
    """A certificate file of format version 4 (see the module docstring)."""

    format: Literal["auv-hinf-certificate"]
    version: Literal[4]
    tool_version: str
    created: str = Field(description="ISO 8601 time stamp, UTC")
    config: dict[str, Any] = Field(description="the configuration, as its TOML tables")
    certificate: CertificateRecord
    digest: str = Field(pattern=r"^sha256:[0-9a-f]{64}$", description="SHA-256 of the canonical config and record")


def certificate_schema() -> dict[str, Any]:
    """The JSON Schema of a certificate file of format version 4."""
    schema = CertificateDocument.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "auv-hinf certificate file, format version 4"
    return schema


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by ``None`` and tuples by lists (the CLI's JSON rule).

    Parameters
    ----------
    obj : Any
        A value of JSON types (dicts, lists, tuples, scalars), nested.
    """
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def json_normal(obj: Any) -> Any:
    """``obj`` as it reads back from a JSON file: :func:`json_safe`, then a dump/parse round trip.

    Parameters
    ----------
    obj : Any
        A value of JSON types, nested.
    """
    return json.loads(json.dumps(json_safe(obj), allow_nan=False))


def digest(config: Any, record: Any) -> str:
    """``sha256:`` and the hex digest of the canonical JSON (sorted keys, no spaces) of both.

    Parameters
    ----------
    config : Any
        The stored configuration (its TOML tables, JSON-normal).
    record : Any
        The stored certificate record (JSON-normal).
    """
    text = json.dumps({"config": config, "certificate": record}, sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def certificate_document(cert: StoredCertificate, created: datetime | None = None) -> dict[str, Any]:
    """The stored document of ``cert`` (see the module docstring).

    Parameters
    ----------
    cert : Certificate
    created : datetime, optional
        Time stamp (default: now, UTC).
    """
    stamp = (created or datetime.now(timezone.utc)).astimezone(timezone.utc)
    config = json_normal(cert.config.to_toml_dict())
    record = json_normal(cert.to_dict())
    return {
        "format": FORMAT,
        "version": VERSION,
        "tool_version": __version__,
        "created": stamp.isoformat(),
        "config": config,
        "certificate": record,
        "digest": digest(config, record),
    }


def _legacy_record(version: int, config: FormationConfig, record: dict[str, Any]) -> dict[str, Any]:
    """A version 1-3 record in the version 4 layout: its parts listed, its gains named."""
    parts: dict[str, Any] = {
        "theorem1": {
            "ok": True,
            "applies": True,
            "reasons": [],
            "key": None,
            "keys": [k for k in LEGACY_THEOREM1_KEYS if k in record],
        }
    }
    for key in LEGACY_PART_KEYS:
        if key in record:
            parts[key] = {"ok": True, "applies": record[key] is not None, "reasons": [], "key": key}
    parts["recorded"] = {
        "ok": bool(record["certified"]),
        "applies": True,
        "reasons": [{"part": "recorded", "kind": "not_covered", "message": str(m)} for m in record["reasons"]],
        "key": None,
        "keys": [],
        "note": f"the verdict recorded by format version {version}",
    }
    out = {**record, "parts": parts}
    if "gains" not in record:  # version 1: the gains that ran, from the record and the configuration
        out["gains"] = _gains_of_version_1(config, record)
    out.setdefault("design", None)
    return out


def _gains_of_version_1(config: FormationConfig, record: dict[str, Any]) -> dict[str, Any] | None:
    """The gains that ran for a version 1 record: the robust design's, or the Theorem 1 gains."""
    if config.robust:
        rob = record.get("robust") or {}
        g = rob.get("gains")
        return None if g is None else {**g, "source": "robust"}
    alpha = (record.get("alpha") or {}).get("used")
    if alpha is None:
        return None
    k_psi = heading_gains(config.vehicle, config.heading_poles)
    return {"alpha": alpha, "k1": config.k1, "k_psi": list(k_psi), "source": "theorem1"}


#: Scalar fields of the tagged state of version 1-3 files and where the record holds them: an
#: edited record disagrees with its state on one of these (the state itself is not rebuilt).
LEGACY_STATE_SCALARS = {
    "lam": ("lambda",),
    "gamma": ("gamma",),
    "alpha_used": ("alpha", "used"),
    "small_gain_margin": ("small_gain_margin",),
    "position_loop_hinf": ("position_loop_hinf",),
    "certified": ("certified",),
}


def _legacy_state_agrees(state: Any, record: dict[str, Any], source: str) -> None:
    """Refuse a version 1-3 record whose scalars disagree with the tagged state stored beside it."""
    if not isinstance(state, dict):
        raise ConfigError(f"{source}: certificate file lacks the object(s) ['state']")
    for name, path in LEGACY_STATE_SCALARS.items():
        value = state.get(name)
        if isinstance(value, dict) and set(value) == {"$float"}:
            value = None  # a non-finite float, which the record holds as null
        if value is not None and not isinstance(value, (bool, int, float)):
            continue
        found: Any = record
        for key in path:
            found = found.get(key) if isinstance(found, dict) else None
        if found != value:
            raise ConfigError(
                f"{source}: the certificate record disagrees with its stored state in [{path[0]!r}] (edited file?)"
            )


def _consistent(config: FormationConfig, record: CertificateRecord, source: str) -> None:
    """Refuse a record that disagrees with its configuration or whose verdict disagrees with its parts."""
    expected = json_normal({"n": config.n, "envelope": config.envelope.to_dict(), "vehicle": config.vehicle.to_dict()})
    found = {"n": record.n, "envelope": record.envelope, "vehicle": record.vehicle}
    wrong = sorted(k for k in expected if expected[k] != found[k])
    if wrong:
        raise ConfigError(
            f"{source}: the certificate record disagrees with its configuration in {wrong} (edited file?)"
        )
    if record.certified != all(p.ok for p in record.parts.values()):
        raise ConfigError(f"{source}: 'certified' disagrees with the verdicts of the parts (edited file?)")
    messages = [r.message for p in record.parts.values() if not p.ok for r in p.reasons]
    if messages != record.reasons:
        raise ConfigError(f"{source}: 'reasons' disagree with the reasons of the parts (edited file?)")


_Model = TypeVar("_Model", bound=BaseModel)


def _validated(model: type[_Model], data: Any, what: str) -> _Model:
    """``data`` validated as ``model``, or a one-line error naming the first place it breaks the schema."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(x) for x in first["loc"])
        raise ConfigError(f"{what} at {where}: {first['msg']}") from None


def record_from_document(doc: Any, source: str = "certificate") -> tuple[FormationConfig, dict[str, Any]]:
    """The configuration and the version 4 record of a parsed certificate file of any version.

    The record is validated against the schema and against its configuration;
    :meth:`~auv_hinf.certificate.assembly.Certificate.from_record` makes the certificate of it.

    Parameters
    ----------
    doc : Any
        The parsed JSON document.
    source : str
        Name of the document (a file name), starting every message.

    Raises
    ------
    ConfigError
        If the format or version differs, the layout is not the schema's, the configuration is
        invalid, the digest does not match, or the record disagrees with itself or its configuration.
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
    missing = [k for k in ("config", "certificate") if not isinstance(doc.get(k), dict)]
    if missing:
        raise ConfigError(f"{source}: certificate file lacks the object(s) {missing}")
    try:
        config = config_from_dict(doc["config"])
    except ConfigError as exc:
        raise ConfigError("\n".join(f"{source}: config: {line}" for line in str(exc).splitlines())) from None
    if version == VERSION:
        parsed = _validated(CertificateDocument, doc, f"{source}: not a valid certificate file")
        if parsed.digest != digest(doc["config"], doc["certificate"]):
            raise ConfigError(f"{source}: the digest does not match the record (edited or truncated file?)")
        raw = doc["certificate"]
    else:
        _legacy_state_agrees(doc.get("state"), doc["certificate"], source)
        raw = _legacy_record(version, config, doc["certificate"])
    record = _validated(CertificateRecord, raw, f"{source}: not a valid certificate record")
    _consistent(config, record, source)
    return config, raw


def save_certificate(cert: StoredCertificate, path: str | Path, *, created: datetime | None = None) -> Path:
    """Write ``cert`` as a certificate file (strict JSON, UTF-8, 2-space indent).

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
        If the file cannot be written.
    """
    p = Path(path)
    text = json.dumps(certificate_document(cert, created), indent=2, allow_nan=False) + "\n"
    try:
        p.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot write certificate {str(p)!r}: {exc.strerror}") from None
    return p


def read_certificate(path: str | Path) -> tuple[FormationConfig, dict[str, Any]]:
    """The configuration and the record of a certificate file of any version (:func:`record_from_document`).

    Parameters
    ----------
    path : str or Path
        The certificate file.

    Raises
    ------
    ConfigError
        If the file cannot be read or is not JSON, or for any reason of :func:`record_from_document`;
        messages start with the file name.
    """
    p = Path(path)
    return record_from_document(read_document(p, "certificate", "JSON", json.loads), source=str(p))


__all__ = [
    "FORMAT",
    "LEGACY_PART_KEYS",
    "LEGACY_STATE_SCALARS",
    "LEGACY_THEOREM1_KEYS",
    "READABLE_VERSIONS",
    "VERSION",
    "CertificateDocument",
    "CertificateRecord",
    "GainsRecord",
    "PartRecord",
    "ReasonRecord",
    "SettingRecord",
    "StoredCertificate",
    "certificate_document",
    "certificate_schema",
    "digest",
    "json_normal",
    "json_safe",
    "read_certificate",
    "record_from_document",
    "save_certificate",
]
