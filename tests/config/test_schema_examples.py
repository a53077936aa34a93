"""The schema's examples are valid together: a table built from them loads."""

from __future__ import annotations

import pytest

from auv_hinf.config.schema import REFERENCE_MODELS, ActuatorsTable
from auv_hinf.config.settings import config_from_dict


@pytest.mark.parametrize("kind", sorted(REFERENCE_MODELS))
def test_reference_examples_make_a_valid_mission(kind):
    model = REFERENCE_MODELS[kind]
    table = {"kind": kind}
    table |= {name: info.examples[0] for name, info in model.model_fields.items() if name != "kind" and info.examples}
    cfg = config_from_dict({"reference": table})
    assert cfg.reference.kind == kind


def test_actuator_examples_make_valid_limits():
    table = {name: info.examples[0] for name, info in ActuatorsTable.model_fields.items() if info.examples}
    cfg = config_from_dict({"actuators": table})
    assert cfg.actuators is not None and cfg.actuators.limits() == (table["tau_x"], table["tau_y"], table["tau_psi"])
