"""Streaming campaign metrics against the post-processing of stored samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.campaign.setup import prepare
from auv_hinf.certificate.run_plan import measured_decay_rate
from auv_hinf.config.presets import preset_config
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.simulation.engine import integrate_batch, simulate_batch
from auv_hinf.simulation.metrics import ErrorSink, decay_rates
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch

#: Relative difference allowed between two roundings of the same norm: four units in the last place.
ULPS = 4 * np.finfo(float).eps


def _batch(rng: np.random.Generator) -> tuple[ScenarioBatch, object]:
    """Paper-triangle runs with perturbed plants, currents and starts (not all certified)."""
    setup, cert = prepare(preset_config("paper-triangle"), seed=0, horizon=40.0)
    nominal = setup.nominal
    scns = []
    for k in range(5):
        start = np.column_stack(
            [setup.start[:, 0] + rng.normal(0, 2, (3, 2)), setup.start[:, 2, 0] + rng.normal(0, 0.2, 3)]
        )
        vel = np.column_stack([np.full(3, 1.0), rng.normal(0, 0.05, 3), rng.normal(0, 0.02, 3)])
        plant = nominal if k == 0 else VehicleParams(**{**nominal.__dict__, "m11": nominal.m11 * (0.9 + 0.05 * k)})
        scns.append(
            Scenario(
                law=setup.law,
                reference=setup.reference,
                plant=plant,
                initial=np.column_stack([start, vel]),
                horizon=setup.horizon,
                current=(0.0, 0.0) if k == 0 else tuple(rng.normal(0, 0.1, 2)),
                samples=setup.samples,
            )
        )
    return ScenarioBatch(tuple(scns)), cert


@pytest.mark.slow
def test_streamed_metrics_equal_the_stored_sample_post_processing(rng: np.random.Generator) -> None:
    batch, cert = _batch(rng)
    sink = ErrorSink(
        batch.source, batch.scenarios[0].times, batch.current, 3, cert.position.matrix, cert.heading.matrix
    )
    sol = integrate_batch(batch, sink=sink)
    met = sink.result()
    results = simulate_batch(batch)  # independent path: stored samples, whole-array post-processing
    for k, res in enumerate(results):
        tr = res.tracking
        want = np.stack(
            [
                np.linalg.norm(tr.e, axis=-1).max(0),
                np.linalg.norm(tr.e_dot, axis=-1).max(0),
                np.abs(tr.e_psi).max(0),
                np.abs(tr.e_psi_dot).max(0),
            ],
            -1,
        )
        # the sink takes norms with hypot, the stored path with linalg.norm: equal up to an ulp or two
        np.testing.assert_allclose(met.max_errors[k], want, rtol=ULPS, atol=0)
        half = res.t.size // 2
        np.testing.assert_allclose(met.tail_position[k], np.linalg.norm(tr.e[half:], axis=-1).max(0), rtol=ULPS)
        np.testing.assert_allclose(met.final_position[k], res.mission_error[-1], rtol=ULPS, atol=0)
        rate = measured_decay_rate(res, cert)
        assert (rate is None and math.isnan(met.decay_rate[k])) or met.decay_rate[k] == pytest.approx(rate, rel=1e-12)
        assert sol.n_steps[k] == res.n_steps


def test_decay_rates_skip_vehicles_without_a_start_error() -> None:
    # rate of V falling from 4 to 4e-6 in 2 s: ln(sqrt(1e6)) / 2
    v0, vk, tk = np.array([4.0, 0.0, 4.0]), np.array([4e-6, 0.0, 1.0]), np.array([2.0, 2.0, 0.0])
    assert decay_rates(v0, vk, tk) == pytest.approx(math.log(1e3) / 2.0, rel=1e-14)
    assert math.isnan(float(decay_rates(np.zeros(3), np.zeros(3), np.ones(3))))
