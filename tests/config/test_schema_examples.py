"""The schema's examples are valid together: a table built from them loads."""

from __future__ import annotations

import pytest

from auv_hinf.config.schema import REFERENCE_MODELS, ActuatorsTable
from auv_hinf.config.settings import config_from_dict
from auv_hinf.exceptions import ConfigError


@pytest.mark.parametrize("kind", sorted(REFERENCE_MODELS))
def test_reference_examples_make_a_valid_mission(kind):
    model = REFERENCE_MODELS[kind]
    table = {"kind": kind}
    table |= {name: info.examples[0] for name, info in model.model_fields.items() if name != "kind" and info.examples}
    cfg = config_from_dict({"reference": table})
    assert cfg.reference.kind == kind


#: The keys of each ``[actuators] kind``.
ACTUATOR_KEYS = {
    "fully-actuated": ("tau_x", "tau_y", "tau_psi"),
    "underactuated": ("tau_x", "rudder_max", "rudder_sway", "rudder_yaw"),
}


@pytest.mark.parametrize("kind", sorted(ACTUATOR_KEYS))
def test_actuator_examples_make_valid_limits(kind):
    fields = ActuatorsTable.model_fields
    table = {"kind": kind} | {k: fields[k].examples[0] for k in ACTUATOR_KEYS[kind]}  # type: ignore[index]
    cfg = config_from_dict({"actuators": table})
    assert cfg.actuators is not None and cfg.actuators.kind == kind
    assert {k: getattr(cfg.actuators, k) for k in ACTUATOR_KEYS[kind]} == {k: table[k] for k in ACTUATOR_KEYS[kind]}
    assert config_from_dict(cfg.to_toml_dict()).actuators == cfg.actuators


@pytest.mark.parametrize("kind", sorted(ACTUATOR_KEYS))
def test_an_actuator_key_of_the_other_kind_is_refused_by_name(kind):
    other = next(k for k in ACTUATOR_KEYS if k != kind)
    stray = next(k for k in ACTUATOR_KEYS[other] if k not in ACTUATOR_KEYS[kind])
    fields = ActuatorsTable.model_fields
    table = {"kind": kind} | {k: fields[k].examples[0] for k in (*ACTUATOR_KEYS[kind], stray)}  # type: ignore[index]
    with pytest.raises(ConfigError, match=rf"{stray} do not apply to kind = '{kind}'"):
        config_from_dict({"actuators": table})
