"""The part protocol: a part registered from outside the package shows in the JSON, text, file and exit code."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pytest

from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.part import (
    ALL_LAWS,
    FORMATION_LAW,
    LAW_IDLE,
    ControlLaw,
    PartContext,
    RunCheck,
    RunContext,
    Verdict,
    part_laws,
)
from auv_hinf.certificate.reason import REASON_KINDS, Reason, Setting, toml_line
from auv_hinf.certificate.registry import PARTS, parts, register_part, unregister_part
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.exceptions import ParameterError


@dataclass(frozen=True)
class SpacingPart:
    """A test part: every two slots of the shape at least ``spacing`` m apart."""

    spacing: float
    name: str = "spacing"
    key: str | None = "spacing_check"
    laws: tuple[ControlLaw, ...] = ALL_LAWS

    def evaluate(self, ctx: PartContext) -> Verdict:
        off = ctx.point.offsets
        d = np.hypot(*(off[:, None, :] - off[None, :, :]).transpose(2, 0, 1))
        closest = float(d[np.triu_indices(len(off), 1)].min())
        figures = {"closest": closest, "required": self.spacing}
        if closest >= self.spacing:
            return Verdict(self.name, True, True, (), figures)
        why = Reason(
            self.name,
            "envelope",
            f"slots only {closest:.3g} m apart, {self.spacing:g} m needed",
            channel="spacing",
            value=closest,
            limit=self.spacing,
            settings=(Setting("formation", "radius", self.spacing),),
        )
        return Verdict(self.name, False, True, (why,), figures)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        return [f"  slot spacing              {figures['closest']:.4g} m (needed {figures['required']:g} m)"]

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        return None


@pytest.fixture
def registered(request):
    part = SpacingPart(request.param)
    register_part(part, after="actuators")
    try:
        yield part
    finally:
        unregister_part(part.name)
    assert [p.name for p in parts()] == [p.name for p in PARTS]


@pytest.mark.slow
@pytest.mark.parametrize("registered", [1e6], indirect=True)
def test_a_failing_plug_in_part_is_in_the_json_the_text_the_file_and_the_exit_code(registered, tmp_path, capsys):
    cert = certify(preset_config("paper-triangle"))
    record = cert.to_dict()
    assert record["spacing_check"]["required"] == 1e6 and record["spacing_check"]["closest"] > 0
    names = list(record["parts"])
    assert names.index("spacing") == names.index("actuators") + 1
    entry = record["parts"]["spacing"]
    assert entry["ok"] is False and entry["reasons"][0]["kind"] == "envelope"
    assert entry["reasons"][0]["settings"] == [{"table": "formation", "key": "radius", "value": 1e6, "unit": ""}]
    assert not cert.certified and record["certified"] is False
    assert [r.part for r in cert.findings] == ["spacing"] and "slots only" in record["reasons"][0]
    text = cert.summary()
    assert "slot spacing" in text and "CERTIFIED: no" in text and "slots only" in text
    loaded = Certificate.load(cert.save(tmp_path / "c.json"))
    assert loaded.to_dict() == json.loads(json.dumps(record)) and loaded.summary() == text
    assert main(["certify", "--preset", "paper-triangle", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["parts"]["spacing"]["ok"] is False


@pytest.mark.slow
@pytest.mark.parametrize("registered", [0.5], indirect=True)
def test_a_holding_plug_in_part_keeps_the_exit_code_zero(registered, capsys):
    assert main(["certify", "--preset", "paper-triangle"]) == 0
    assert "slot spacing" in capsys.readouterr().out


def test_the_registry_refuses_clashes_and_keeps_its_own_parts():
    with pytest.raises(ParameterError, match="registered already"):
        register_part(PARTS[0])
    with pytest.raises(ParameterError, match="JSON key"):
        register_part(SpacingPart(1.0, name="other", key="robust"))
    with pytest.raises(ParameterError, match="no certificate part called"):
        register_part(SpacingPart(1.0), after="nope")
    with pytest.raises(ParameterError, match="toolbox's own"):
        unregister_part("robust")
    with pytest.raises(ValueError, match="reason kind"):
        Reason("x", "because", "words")
    assert "advice" in REASON_KINDS


@pytest.mark.slow
def test_a_stored_part_that_is_not_registered_still_loads(tmp_path):
    part = SpacingPart(1e6)
    register_part(part)
    try:
        path = certify(preset_config("paper-triangle")).save(tmp_path / "c.json")
    finally:
        unregister_part(part.name)
    loaded = Certificate.load(path)
    assert not loaded.certified and loaded.verdict("spacing") is not None
    assert "spacing" in loaded.summary() and "not registered" in loaded.summary()


@pytest.mark.slow
def test_a_part_is_evaluated_only_for_the_laws_it_declares():
    """A part that declares the formation law only is not run on a [guidance] fleet; one without ``laws`` is."""
    formation_only = replace(SpacingPart(1e6, name="formation_spacing", key="formation_spacing"), laws=FORMATION_LAW)
    every_law = SpacingPart(1e6)
    assert part_laws(every_law) == ALL_LAWS and part_laws(formation_only) == FORMATION_LAW
    register_part(formation_only)
    register_part(every_law)
    try:
        guided = certify(preset_config("remus-survey-ilos"))
    finally:
        unregister_part(formation_only.name)
        unregister_part(every_law.name)
    idle = guided.verdict("formation_spacing")
    assert idle is not None and idle.ok and not idle.applies and idle.note == LAW_IDLE["guidance"]
    ran = guided.verdict("spacing")
    assert ran is not None and ran.applies and not ran.ok  # 1e6 m apart: evaluated, and refused
    # a part may say what covers its concern when its law does not run: the cascade's own certificate
    impl = guided.verdict("implementation")
    assert impl is not None and not impl.applies and "guidance part judges" in impl.note


@pytest.mark.slow
def test_a_box_the_nominal_design_does_not_cover_is_answered_with_the_robust_design():
    """Without ``robust = true`` the nominal Theorem 1 gains run: a box and a current they do not cover are
    refused naming what is declared (a current alone is not called a box) and the key that designs for them."""
    from auv_hinf.config.settings import config_from_dict

    base = {
        "vehicle": {"preset": "paper2011"},
        "formation": {"n": 3, "polygon_radius": 15.0},
        "reference": {"kind": "sine", "speed": 1.5, "amplitude": 30.0, "omega": 0.1},
        "uncertainty": {"m11": [0.9, 1.1], "m22": [0.9, 1.1], "d11_quad": [0.9, 1.1], "d22_quad": [0.9, 1.1]},
        "disturbance": {"current_speed": 0.1},
    }
    cert = certify(config_from_dict(base))
    [why] = [r for r in cert.findings if r.part == "robust"]
    assert "the declared [uncertainty] box and [disturbance] current" in why.message
    assert "[design] robust = true" in why.message
    current_only = certify(config_from_dict({**base, "uncertainty": {}}))
    for r in (r for r in current_only.findings if r.part == "robust"):
        assert "box" not in r.message.split(":")[0]


def test_an_advised_value_carries_the_unit_the_schema_declares_for_its_key():
    """One source for units: the TOML schema's; the sentence and the JSON both give it, TOML stays TOML."""
    current = Setting("disturbance", "current_speed", 0.05)
    assert current.unit == "m/s" and current.to_dict()["unit"] == "m/s"
    assert current.toml() == "[disturbance] current_speed = 0.05"  # exactly what a user writes
    turn = Setting("reference", "turn_radius", 480.0)  # found in the lawn-mower's table
    noise = Setting("implementation.noise", "heading", 0.002)  # a nested table
    box = Setting("uncertainty", "m11", [0.9, 1.1])  # a multiplier: dimensionless
    assert (turn.unit, noise.unit, box.unit) == ("m", "rad", "")
    assert toml_line([current, box, turn]) == (
        "[disturbance] current_speed = 0.05 m/s, [uncertainty] m11 = [0.9, 1.1], [reference] turn_radius = 480 m"
    )
    assert Setting.from_dict(current.to_dict()) == current
    shape = Setting("formation", "shape", [[0.0, -5.111801], [0.0, -7.5]])  # a nested array, in metres
    assert shape.toml() == "[formation] shape = [[0, -5.111801], [0, -7.5]]" and shape.words().endswith("]] m")


def test_a_printed_upper_bound_is_never_below_the_bound_and_loses_one_unit_at_most() -> None:
    """``upper`` rounds towards +inf at the requested significant digits (0.140299 m reads 0.141 m, not 0.14 m)."""
    from auv_hinf.certificate.reason import upper

    rng = np.random.default_rng(3)
    values = np.concatenate([10.0 ** rng.uniform(-9, 6, 400), [0.140299, 0.14, 1.0, 99.95, 1e-300]])
    for x in values:
        for d in (3, 4, 5):
            y = float(upper(float(x), d))
            assert y >= x
            assert y - x <= 10.0 ** (np.floor(np.log10(x)) - d + 1) * (1 + 1e-12)
    assert upper(0.140299, 3) == "0.141" and upper(0.14, 3) == "0.14" and upper(float("inf")) == "inf"
