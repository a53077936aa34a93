"""Certificate files: versioned, complete JSON that restores a Certificate exactly."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

import auv_hinf
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.document import (
    FORMAT,
    STORED_TYPES,
    VERSION,
    certificate_document,
    certificate_from_document,
    decode_value,
    encode_value,
)
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict
from auv_hinf.design.sigma import SigmaBounds
from auv_hinf.exceptions import ConfigError
from auv_hinf.models.envelope import Envelope

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


@pytest.fixture(scope="module")
def cert() -> Certificate:
    c = certify(preset_config("paper-triangle"))
    assert c.certified and c.closed_loop is not None and c.closed_loop.shaped is not None
    return c


@pytest.fixture(scope="module")
def failed() -> Certificate:
    """Not certified: the paper gain is infeasible on this envelope, so closed_loop is None."""
    cfg = replace(
        preset_config("paper-triangle"), envelope=Envelope(u=(0, 0.1), v=(-0.1, 0.1), r=(-20, 20)), method="paper"
    )
    c = certify(cfg)
    assert not c.certified and c.closed_loop is None and c.alpha_used is None
    return c


def assert_identical(a: object, b: object, path: str = "cert") -> None:
    """Deep equality that also requires equal types, dtypes, shapes and bit-equal floats."""
    assert type(a) is type(b), f"{path}: {type(a).__name__} != {type(b).__name__}"
    if dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            assert_identical(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray)
        assert a.dtype == b.dtype and a.shape == b.shape, path
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), path
        assert np.array_equal(np.signbit(a.real), np.signbit(b.real)) if a.dtype.kind in "fc" else True, path
    elif isinstance(a, dict):
        assert isinstance(b, dict)
        assert list(a) == list(b), path
        for k in a:
            assert_identical(a[k], b[k], f"{path}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple))
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_identical(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert isinstance(b, float)
        assert (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b)), path
    else:
        assert a == b, path


def normal(d: dict) -> dict:
    """JSON-normalised (what a JSON file holds): NaN/inf become null as in the CLI output."""

    def safe(x: object) -> object:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: safe(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [safe(v) for v in x]
        return x

    return json.loads(json.dumps(safe(d)))


@pytest.mark.parametrize("which", ["cert", "failed"])
def test_round_trip_is_exact(which, request, tmp_path):
    c = request.getfixturevalue(which)
    path = c.save(tmp_path / "c.json")
    assert path == tmp_path / "c.json"
    loaded = Certificate.load(path)
    assert normal(loaded.to_dict()) == normal(c.to_dict())
    assert loaded.certified == c.certified and loaded.reasons == c.reasons
    assert loaded.config == c.config  # rebuilt from the TOML tables alone
    assert_identical(loaded, c)
    assert loaded.summary() == c.summary()


def test_second_save_is_byte_identical_apart_from_the_time_stamp(cert, tmp_path):
    first = cert.save(tmp_path / "a.json").read_text(encoding="utf-8")
    second = Certificate.load(tmp_path / "a.json").save(tmp_path / "b.json").read_text(encoding="utf-8")

    def strip(text: str) -> list[str]:
        return [line for line in text.splitlines() if not line.lstrip().startswith('"created"')]

    assert strip(first) == strip(second)
    assert len(first.splitlines()) == len(strip(first)) + 1
    stamp = datetime(2030, 1, 2, 3, 4, 5, tzinfo=timezone.utc)
    from auv_hinf.certificate.document import save_certificate

    a = save_certificate(cert, tmp_path / "x.json", created=stamp).read_bytes()
    b = save_certificate(Certificate.load(tmp_path / "x.json"), tmp_path / "y.json", created=stamp).read_bytes()
    assert a == b


def test_document_header_and_complete_config(cert, tmp_path):
    text = cert.save(tmp_path / "c.json").read_text(encoding="utf-8")

    def no_constants(name: str) -> None:
        raise AssertionError(f"non-strict JSON constant {name}")

    doc = json.loads(text, parse_constant=no_constants)
    assert list(doc) == ["format", "version", "tool_version", "created", "config", "certificate", "state"]
    assert doc["format"] == FORMAT == "auv-hinf-certificate" and doc["version"] == VERSION == 3
    assert doc["tool_version"] == auv_hinf.__version__
    created = datetime.fromisoformat(doc["created"])
    assert created.utcoffset() is not None and created.utcoffset().total_seconds() == 0
    assert abs((datetime.now(timezone.utc) - created).total_seconds()) < 600
    assert doc["config"] == json.loads(json.dumps(cert.config.to_toml_dict()))
    assert config_from_dict(doc["config"]) == cert.config
    for table in ("vehicle", "formation", "envelope", "design", "reference", "simulation"):
        assert table in doc["config"]
    assert doc["config"]["design"]["heading_poles"] == list(cert.config.heading_poles)
    assert doc["certificate"] == normal(cert.to_dict())
    assert doc["certificate"]["certified"] is True


def test_loaded_objects_work_like_the_originals(cert, tmp_path):
    loaded = Certificate.load(cert.save(tmp_path / "c.json"))
    a, b = cert.closed_loop, loaded.closed_loop
    assert a is not None and b is not None and a.certificate is not None and b.certificate is not None
    assert isinstance(b.certificate.region.p2, np.ndarray) and b.certificate.region.p2.shape == (2, 2)
    assert a.shaped is not None and b.shaped is not None
    # the shaped fleet reference (mission object + blend arrays) is restored, not re-derived
    t = np.linspace(0.0, 80.0, 17)
    ma, mb = a.shaped.reference.motion(t), b.shaped.reference.motion(t)
    for f in ("p", "v", "a", "psi", "r", "r_dot"):
        assert np.array_equal(getattr(ma, f), getattr(mb, f)), f
    assert b.shaped.reference.shaping is not None and b.shaped.blend_time == a.shaped.blend_time


@pytest.mark.parametrize(
    "value",
    [
        math.inf,
        -math.inf,
        -0.0,
        1e-310,
        0.1 + 0.2,
        3,
        True,
        None,
        "s",
        (1.0, (2, "x")),
        [1, (2,)],
        {"a": (1.5, None), "b": {"c": [math.inf]}},
        complex(1.5, -2.0),
        np.float64(0.3),
        np.bool_(True),
        np.int32(-7),
        np.array([[1.0, -0.0], [math.inf, 2.5e-300]]),
        np.arange(6, dtype=np.int64).reshape(2, 3, 1),
        np.zeros((0, 2)),
        np.array([1 + 2j]),
        np.array(True),
    ],
)
def test_encode_decode_round_trip(value):
    enc = encode_value(value)
    text = json.dumps(enc, allow_nan=False)
    assert_identical(decode_value(json.loads(text)), value, "value")


def test_nan_round_trip():
    out = decode_value(json.loads(json.dumps(encode_value((math.nan, np.array([math.nan]))), allow_nan=False)))
    assert math.isnan(out[0]) and np.isnan(out[1][0])


@pytest.mark.parametrize("value", [object(), {1: 2}, np.array(["a"]), np.array([None], dtype=object)])
def test_encode_refuses_unknown_values(value):
    with pytest.raises(ConfigError, match="cannot store"):
        encode_value(value)


def _doc(cert: Certificate) -> dict:
    return json.loads(json.dumps(certificate_document(cert), allow_nan=False))


def test_load_refuses_wrong_format_and_version(cert, tmp_path):
    doc = _doc(cert)
    with pytest.raises(ConfigError, match="not an auv-hinf certificate file"):
        certificate_from_document({**doc, "format": "something-else"}, Certificate)
    with pytest.raises(ConfigError, match="not an auv-hinf certificate file"):
        certificate_from_document([doc], Certificate)
    for bad in (VERSION + 1, 0, "1", True, None):
        with pytest.raises(ConfigError, match="unsupported certificate version"):
            certificate_from_document({**doc, "version": bad}, Certificate)
    with pytest.raises(ConfigError, match="lacks"):
        certificate_from_document({k: v for k, v in doc.items() if k != "state"}, Certificate)
    # the bare `auv-hinf certify --json` output is not a certificate file
    p = tmp_path / "record.json"
    p.write_text(json.dumps(doc["certificate"]), encoding="utf-8")
    with pytest.raises(ConfigError, match=r"record\.json: not an auv-hinf certificate file"):
        Certificate.load(p)


def test_load_refuses_edited_files(cert, tmp_path):
    doc = _doc(cert)
    edited = json.loads(json.dumps(doc))
    edited["certificate"]["gamma"] = 1.0
    with pytest.raises(ConfigError, match=r"disagrees with its stored state in \['gamma'\]"):
        certificate_from_document(edited, Certificate)
    edited = json.loads(json.dumps(doc))
    edited["state"]["alpha_used"] = 0.5
    with pytest.raises(ConfigError, match="disagrees"):
        certificate_from_document(edited, Certificate)
    edited = json.loads(json.dumps(doc))
    edited["config"]["design"]["k1"] = 0.25  # the record says k1 = 0.5
    with pytest.raises(ConfigError, match="disagrees"):
        certificate_from_document(edited, Certificate)
    edited = json.loads(json.dumps(doc))
    edited["config"]["design"]["k1"] = -1.0
    with pytest.raises(ConfigError, match="config: "):
        certificate_from_document(edited, Certificate)
    edited = json.loads(json.dumps(doc))
    del edited["state"]["gamma"]
    with pytest.raises(ConfigError, match="missing \\['gamma'\\]"):
        certificate_from_document(edited, Certificate)


def test_load_rebuilds_only_package_dataclasses(cert):
    doc = _doc(cert)
    edited = json.loads(json.dumps(doc))
    edited["state"]["crosscheck"]["$dataclass"] = "pathlib:PurePath"
    with pytest.raises(ConfigError, match="not part of auv_hinf"):
        certificate_from_document(edited, Certificate)
    edited["state"]["crosscheck"]["$dataclass"] = "auv_hinf.certificate.assembly:certify"
    with pytest.raises(ConfigError, match="does not exist in this version"):
        certificate_from_document(edited, Certificate)
    edited["state"]["crosscheck"] = {"$evil": 1}
    with pytest.raises(ConfigError, match="unknown tagged value"):
        certificate_from_document(edited, Certificate)


def test_types_are_stored_by_stable_name(cert):
    doc = _doc(cert)
    sigma = doc["state"]["sigma"]
    assert sigma["$dataclass"] == "SigmaBounds"  # no module path: moving the class breaks nothing
    assert STORED_TYPES["SigmaBounds"] is SigmaBounds
    sigma["$dataclass"] = "NoSuchType"
    with pytest.raises(ConfigError, match="does not exist in this version"):
        certificate_from_document(doc, Certificate)


def test_stored_type_names_are_unique_and_cover_the_certificate(cert):
    names = [cls.__name__ for cls in STORED_TYPES.values()]
    assert len(names) == len(set(names))
    text = json.dumps(_doc(cert)["state"])
    assert set(re.findall(r'"\$dataclass": "([^"]+)"', text)) <= set(STORED_TYPES)


@pytest.mark.parametrize("preset", ["paper-triangle", pytest.param("remus-line", marks=pytest.mark.slow)])
def test_version_1_files_of_0_2_0_still_load(preset):
    path = FIXTURES / f"certificate-v0.2.0-{preset}.json"
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["version"] == 1 and doc["tool_version"] == "0.2.0"
    old = Certificate.load(path)
    now = design_point(preset_config(preset))  # today's design of the same configuration
    assert old.certified is doc["certificate"]["certified"] is True
    used = now.designs[old.config.method]
    assert used is not None and old.alpha_used == doc["certificate"]["alpha"]["used"] == used.alpha
    # the gains that ran in 0.2.0 are restored: the robust design's, or the Theorem 1 gains
    assert old.gain_source == now.source
    assert old.gains is not None and now.gains is not None
    np.testing.assert_allclose(
        [old.gains.alpha, old.gains.k1, *old.gains.k_psi], [now.gains.alpha, now.gains.k1, *now.gains.k_psi], rtol=1e-9
    )
    # an old file saved again is a current-version file that loads to the same certificate
    again = certificate_from_document(_doc(old), Certificate)
    assert again.gains == old.gains and again.to_dict() == old.to_dict()


def test_version_1_file_with_an_edited_record_is_refused():
    doc = json.loads((FIXTURES / "certificate-v0.2.0-paper-triangle.json").read_text(encoding="utf-8"))
    doc["certificate"]["gamma"] = 1.0
    with pytest.raises(ConfigError, match="disagrees"):
        certificate_from_document(doc, Certificate)


def test_unreadable_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot read certificate"):
        Certificate.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ConfigError, match="invalid JSON"):
        Certificate.load(bad)
