"""Shared fixtures and strategies."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import settings

from auv_hinf.models.vehicle import VehicleParams, paper2011, remus100

settings.register_profile("ci", max_examples=40, deadline=None)
settings.load_profile("ci")

VEHICLES = {"paper2011": paper2011(), "remus100": remus100()}


@pytest.fixture(params=sorted(VEHICLES))
def vehicle(request: pytest.FixtureRequest) -> VehicleParams:
    return VEHICLES[request.param]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20111)
