"""Versioned, complete certificate files: save a :class:`~auv_hinf.workflow.certificate.Certificate`
as JSON and load it back exactly (this module never imports the certificate type: the caller
passes it, so the certificate can use this module without an import cycle).

A certificate file is one JSON object::

    {
      "format": "auv-hinf-certificate",
      "version": 2,
      "tool_version": "<auv_hinf.__version__ that wrote it>",
      "created": "<ISO 8601 time stamp, UTC>",
      "config": {... FormationConfig.to_toml_dict() ...},
      "certificate": {... Certificate.to_dict(), the ``auv-hinf certify --json`` layout ...},
      "state": {... every other field of the Certificate, exactly ...}
    }

``config`` makes the file complete: vehicle, shape, envelope, design, heading poles,
reference, simulation, uncertainty and disturbance settings (``config_from_dict`` rebuilds
the :class:`~auv_hinf.config.formation.FormationConfig`). ``certificate`` is the readable
record (non-finite numbers written as ``null``, as the CLI does). ``state`` restores every
other field *exactly*, without re-running :func:`~auv_hinf.workflow.certificate.certify`:
each value is stored in the tagged form of :mod:`auv_hinf.workflow.codec`, which keeps its
type. Loading checks the format and version, and that the readable record equals the
``to_dict()`` of the rebuilt certificate, so an edited or truncated file is refused with a
:class:`~auv_hinf.exceptions.ConfigError` rather than silently believed.

Version 1 files (auv-hinf 0.2.0) named classes ``"auv_hinf.module:Class"`` and had no
``gains`` in the certificate state. They still load: the class name is looked up in the
registry of :mod:`auv_hinf.workflow.codec`, the gains that ran are restored from
the state (the robust design's when ``[design] robust = true``, else the configured Theorem 1
gains), and the readable record is checked on every key the version 1 file has.
"""

from __future__ import annotations

import dataclasses
import json
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Protocol, TypeVar, cast

from auv_hinf._version import __version__
from auv_hinf.config.formation import FormationConfig, config_from_dict
from auv_hinf.design.gains import Gains, heading_gains
from auv_hinf.exceptions import ConfigError
from auv_hinf.workflow.codec import decode_value, encode_value, json_normal

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
    """Rebuild the :class:`~auv_hinf.workflow.certificate.Certificate` of a document of :func:`certificate_document`.

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
    "FORMAT",
    "READABLE_VERSIONS",
    "VERSION",
    "StoredCertificate",
    "certificate_document",
    "certificate_from_document",
    "load_certificate",
    "save_certificate",
]
