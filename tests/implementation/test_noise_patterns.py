"""The noise patterns of a sampled run: at their bounds, in the drawn directions, and against the error."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf._typing import NOISE_PATTERNS
from auv_hinf.certificate.run_plan import run_pattern
from auv_hinf.exceptions import ParameterError
from auv_hinf.implementation.draws import SLOW_HALF_PERIOD, ImplementationDraws, against_noise
from auv_hinf.implementation.model import Implementation, MeasurementNoise

NOISE = MeasurementNoise(0.1, 0.02, 0.02, 0.01)
IMPL = Implementation(0.1, 0.1, noise=NOISE)


def _norms(x: np.ndarray) -> np.ndarray:
    """Per vehicle: |position error|, heading error, |velocity error|, yaw-rate error (absolute)."""
    return np.stack(
        [np.hypot(x[..., 0], x[..., 1]), np.abs(x[..., 2]), np.hypot(x[..., 3], x[..., 4]), np.abs(x[..., 5])], axis=-1
    )


BOUNDS = np.array([NOISE.position, NOISE.heading, NOISE.velocity, NOISE.yaw_rate])


def test_fixed_direction_patterns_sit_at_the_bound_with_their_signs():
    draws = ImplementationDraws(IMPL, [3, 3, 3, 3], 5, ["uniform", "bang-bang", "bias", "slow"])
    half = round(SLOW_HALF_PERIOD / IMPL.sample_time)
    samples = np.stack([draws.noise(k) for k in range(3 * half)])  # (K, S, N, 6)
    for row in (1, 2, 3):
        assert np.allclose(_norms(samples[:, row]), BOUNDS)  # every error at its bound
    uniform = _norms(samples[:, 0])
    assert np.all(uniform <= BOUNDS * (1 + 1e-12)) and np.all(uniform.max(axis=(0, 1)) < BOUNDS)
    assert np.allclose(samples[1, 1], -samples[0, 1]) and np.allclose(samples[2, 1], samples[0, 1])  # bang-bang
    assert np.allclose(samples[:, 2], samples[0, 2])  # bias: constant
    assert np.allclose(samples[half - 1, 3], samples[0, 3]) and np.allclose(samples[half, 3], -samples[0, 3])
    # a vehicle's direction depends on its seed and index only, not on the other runs
    alone = ImplementationDraws(IMPL, [3], 5, ["bias"])
    assert np.allclose(alone.noise(0)[0], samples[0, 2])


def test_against_error_opposes_every_channel_at_its_bound():
    rng = np.random.default_rng(0)
    errors = rng.normal(size=(2, 4, 6))
    noise = against_noise(NOISE, errors)
    assert np.allclose(_norms(noise), BOUNDS)
    assert np.all(noise[..., 0] * errors[..., 0] + noise[..., 1] * errors[..., 1] < 0)  # opposite directions
    assert np.all(noise[..., 2] * errors[..., 2] < 0) and np.all(noise[..., 5] * errors[..., 5] < 0)
    assert np.all(noise[..., 3] * errors[..., 3] + noise[..., 4] * errors[..., 4] < 0)
    # no error: a push all the same (along +x, positive), so a loop on its slot is kicked off it
    kick = against_noise(NOISE, np.zeros((1, 1, 6)))[0, 0]
    assert np.allclose(kick, [-NOISE.position, 0.0, -NOISE.heading, -NOISE.velocity, 0.0, -NOISE.yaw_rate])
    draws = ImplementationDraws(IMPL, [1, 2], 4, ["uniform", "against-error"])
    both = draws.against(errors)
    assert np.allclose(both[0], 0.0) and np.allclose(both[1], noise[1])
    assert np.allclose(draws.noise(0)[1], 0.0)  # the loop adds the opposing errors itself


def test_patterns_are_checked_and_mixed_cycles_through_them():
    with pytest.raises(ParameterError, match="noise pattern"):
        ImplementationDraws(IMPL, [1], 2, ["sideways"])
    assert [run_pattern("mixed", i) for i in range(6)] == [*NOISE_PATTERNS, NOISE_PATTERNS[0]]
    assert run_pattern("bias", 7) == "bias"


def test_scaled_noise_scales_every_bound_and_zero_is_exact():
    half = NOISE.scaled(0.5)
    assert half.to_dict() == {k: 0.5 * v for k, v in NOISE.to_dict().items()}
    assert NOISE.scaled(0.0).exact and not half.exact
    with pytest.raises(ParameterError):
        NOISE.scaled(-1.0)
