"""Certificate files: the documented JSON layout, its schema, the digest, and the files of every version."""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

import auv_hinf
from auv_hinf.certificate.assembly import Certificate, certificate_from_document
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.document import (
    FORMAT,
    VERSION,
    certificate_document,
    certificate_schema,
    digest,
    save_certificate,
)
from auv_hinf.config.presets import PRESETS, preset_config
from auv_hinf.config.settings import config_from_dict
from auv_hinf.exceptions import ConfigError
from tests.helpers import failed_certificate, preset_certificate

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
SCHEMA_FILE = Path(__file__).resolve().parents[2] / "docs" / "certificate.schema.json"


@pytest.fixture(scope="module")
def cert() -> Certificate:
    c = preset_certificate("paper-triangle")
    assert c.certified and c.closed_loop is not None and c.closed_loop.shaped is not None
    return c


@pytest.fixture(scope="module")
def failed() -> Certificate:
    c = failed_certificate()
    assert not c.certified and c.closed_loop is None and c.alpha_used is None
    return c


def _doc(cert: Certificate) -> dict:
    return json.loads(json.dumps(certificate_document(cert), allow_nan=False))


def _normal(d: dict) -> dict:
    return json.loads(json.dumps(auv_hinf.certificate.document.json_safe(d), allow_nan=False))


@pytest.mark.parametrize("which", ["cert", "failed"])
def test_round_trip_keeps_record_verdicts_text_and_gains(which, request, tmp_path):
    c = request.getfixturevalue(which)
    path = c.save(tmp_path / "c.json")
    assert path == tmp_path / "c.json"
    loaded = Certificate.load(path)
    assert loaded.to_dict() == _normal(c.to_dict())
    assert loaded.certified == c.certified and loaded.reasons == c.reasons
    assert loaded.findings == c.findings  # reasons as data: part, kind, channel, vehicle, value, limit, settings
    assert loaded.config == c.config  # rebuilt from the TOML tables alone
    assert loaded.gains == c.gains and loaded.gain_source == c.gain_source
    assert loaded.summary() == c.summary()
    assert [v.part for v in loaded.verdicts] == [v.part for v in c.verdicts]
    assert all(v.detail is None for v in loaded.verdicts)  # the typed results are not stored


def test_the_loaded_law_is_the_certified_law(cert, tmp_path):
    loaded = Certificate.load(cert.save(tmp_path / "c.json"))
    a, b = cert.controller(), loaded.controller()
    x = np.random.default_rng(4).normal(size=a.ninputs)
    np.testing.assert_array_equal(a.output(0.0, [], x), b.output(0.0, [], x))


def test_second_save_is_byte_identical_apart_from_the_time_stamp(cert, tmp_path):
    stamp = datetime(2030, 1, 2, 3, 4, 5, tzinfo=timezone.utc)
    a = save_certificate(cert, tmp_path / "x.json", created=stamp).read_bytes()
    b = save_certificate(Certificate.load(tmp_path / "x.json"), tmp_path / "y.json", created=stamp).read_bytes()
    assert a == b


def test_document_layout(cert, tmp_path):
    text = cert.save(tmp_path / "c.json").read_text(encoding="utf-8")

    def no_constants(name: str) -> None:
        raise AssertionError(f"non-strict JSON constant {name}")

    doc = json.loads(text, parse_constant=no_constants)
    assert list(doc) == ["format", "version", "tool_version", "created", "config", "certificate", "digest"]
    assert doc["format"] == FORMAT == "auv-hinf-certificate" and doc["version"] == VERSION == 4
    assert doc["tool_version"] == auv_hinf.__version__
    created = datetime.fromisoformat(doc["created"])
    assert created.utcoffset() is not None and created.utcoffset().total_seconds() == 0
    assert config_from_dict(doc["config"]) == cert.config
    assert doc["certificate"] == _normal(cert.to_dict())  # exactly the certify --json record
    assert doc["digest"] == digest(doc["config"], doc["certificate"])
    assert "$dataclass" not in text and "auv_hinf." not in text  # no Python class names


def test_published_schema_is_current_and_validates_every_file(cert, failed):
    jsonschema = pytest.importorskip("jsonschema")
    published = json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))
    assert published == certificate_schema(), "run: auv-hinf schema --certificate > docs/certificate.schema.json"
    validator = jsonschema.Draft202012Validator(published)
    for c in (cert, failed):
        validator.validate(_doc(c))
    bad = _doc(cert)
    bad["certificate"]["parts"]["theorem1"]["reasons"] = [{"part": "theorem1", "kind": "nonsense", "message": "x"}]
    assert list(validator.iter_errors(bad))


def test_load_refuses_wrong_format_version_and_layout(cert, tmp_path):
    doc = _doc(cert)
    with pytest.raises(ConfigError, match="not an auv-hinf certificate file"):
        certificate_from_document({**doc, "format": "something-else"})
    with pytest.raises(ConfigError, match="not an auv-hinf certificate file"):
        certificate_from_document([doc])
    for bad in (VERSION + 1, 0, "1", True, None):
        with pytest.raises(ConfigError, match="unsupported certificate version"):
            certificate_from_document({**doc, "version": bad})
    with pytest.raises(ConfigError, match="lacks"):
        certificate_from_document({k: v for k, v in doc.items() if k != "certificate"})
    with pytest.raises(ConfigError, match="not a valid certificate file at digest"):
        certificate_from_document({k: v for k, v in doc.items() if k != "digest"})
    p = tmp_path / "record.json"  # the bare `auv-hinf certify --json` output is not a certificate file
    p.write_text(json.dumps(doc["certificate"]), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"record\.json: not an auv-hinf certificate file"):
        Certificate.load(p)


def _redigest(doc: dict) -> dict:
    doc["digest"] = digest(doc["config"], doc["certificate"])
    return doc


def test_load_refuses_edited_files(cert):
    doc = _doc(cert)
    edited = json.loads(json.dumps(doc))
    edited["certificate"]["gamma"] = 1.0
    with pytest.raises(ConfigError, match="digest does not match"):
        certificate_from_document(edited)
    edited = json.loads(json.dumps(doc))
    edited["config"]["design"]["k1"] = 0.25
    with pytest.raises(ConfigError, match="digest does not match"):
        certificate_from_document(edited)
    # re-digested edits are still caught where the record disagrees with itself or its configuration
    edited = json.loads(json.dumps(doc))
    edited["certificate"]["vehicle"]["m11"] = 1.5 * edited["certificate"]["vehicle"]["m11"]
    with pytest.raises(ConfigError, match=r"disagrees with its configuration in \['vehicle'\]"):
        certificate_from_document(_redigest(edited))
    edited = json.loads(json.dumps(doc))
    edited["certificate"]["parts"]["closed_loop"]["ok"] = False
    with pytest.raises(ConfigError, match="'certified' disagrees"):
        certificate_from_document(_redigest(edited))
    edited = json.loads(json.dumps(doc))
    edited["config"]["design"]["k1"] = -1.0
    with pytest.raises(ConfigError, match="config: "):
        certificate_from_document(_redigest(edited))


@pytest.mark.parametrize(
    "name", [pytest.param(p, marks=pytest.mark.slow) if p != "paper-triangle" else p for p in sorted(PRESETS)]
)
def test_every_preset_saves_and_loads(name, tmp_path):
    c = preset_certificate(name)
    loaded = Certificate.load(c.save(tmp_path / f"{name}.json"))
    assert loaded.to_dict() == _normal(c.to_dict()) and loaded.summary() == c.summary()


@pytest.mark.parametrize(
    "fixture",
    [
        "certificate-v0.2.0-paper-triangle.json",
        "certificate-format-v2-paper-triangle.json",
        "certificate-format-v3-paper-triangle.json",
        pytest.param("certificate-v0.2.0-remus-line.json", marks=pytest.mark.slow),
        pytest.param("certificate-format-v2-remus-line.json", marks=pytest.mark.slow),
        pytest.param("certificate-format-v3-remus-line.json", marks=pytest.mark.slow),
    ],
)
def test_files_of_format_versions_1_to_3_still_load(fixture, tmp_path):
    path = FIXTURES / fixture
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["version"] in (1, 2, 3)
    old = Certificate.load(path)
    record = old.to_dict()
    for key, value in doc["certificate"].items():  # every key the old record has reads back unchanged
        assert record[key] == value, key
    assert old.certified is doc["certificate"]["certified"] is True
    now = design_point(old.config)  # today's design of the same configuration
    assert old.gain_source == now.source and old.gains is not None and now.gains is not None
    np.testing.assert_allclose(
        [old.gains.alpha, old.gains.k1, *old.gains.k_psi], [now.gains.alpha, now.gains.k1, *now.gains.k_psi], rtol=1e-6
    )
    assert "recorded by format version" in old.summary()
    again = Certificate.load(old.save(tmp_path / "again.json"))  # saved again: a version 4 file
    assert again.to_dict() == old.to_dict() and again.gains == old.gains


@pytest.mark.parametrize(
    "fixture", ["certificate-v0.2.0-paper-triangle.json", "certificate-format-v3-paper-triangle.json"]
)
def test_an_old_file_with_an_edited_record_is_refused(fixture):
    doc = json.loads((FIXTURES / fixture).read_text(encoding="utf-8"))
    doc["certificate"]["gamma"] = 1.0
    with pytest.raises(ConfigError, match=r"disagrees with its stored state in \['gamma'\]"):
        certificate_from_document(doc)


def test_unreadable_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot read certificate"):
        Certificate.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ConfigError, match="invalid JSON"):
        Certificate.load(bad)


def test_a_configuration_can_be_certified_again_from_its_file(cert, tmp_path):
    loaded = Certificate.load(cert.save(tmp_path / "c.json"))
    assert preset_config("paper-triangle") == loaded.config
