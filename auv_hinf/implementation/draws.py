"""Seeded measurement-noise and delay draws of a sampled implementation.

The convention is :mod:`auv_hinf.implementation.model`'s. Each run has an integer ``seed``;
its random numbers come from independent :class:`numpy.random.SeedSequence` streams:

* ``SeedSequence(seed, spawn_key=(NOISE_STREAM, i))`` for the measurement noise of vehicle
  ``i`` (its index in the fleet), six uniforms per sample, consumed sample after sample;
* ``SeedSequence(seed, spawn_key=(DELAY_STREAM,))`` for the delays of a varying delay, one
  uniform per sample, shared by the fleet of the run (the delay of its data link: every vehicle
  measures at the same instants, so the mission is evaluated once per sample).

A vehicle's draws depend only on the seed, its index and the sample index: not on the fleet
size, the other runs of a batch, or the block size in which they are drawn (a generator's
uniforms are one sequential stream). The errors (:func:`noise_from_uniforms`):

* position: uniform in the disc of radius ``noise.position`` (m): radius ``R sqrt(U1)``,
  direction ``2 pi U2``;
* body velocity ``(u, v)``: uniform in the disc of radius ``noise.velocity`` (m/s), the same way;
* heading and yaw rate: uniform on ``[-bound, bound]`` (rad, rad/s).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.numerics.arrays import stack_last

#: First spawn-key word of the noise streams (one per vehicle) and of the delay stream of a run.
NOISE_STREAM, DELAY_STREAM = 1, 2
#: Samples drawn at once per stream: the draws are the same for any block size (see the module
#: note); this only trades Python calls against memory (``S N BLOCK 6`` doubles per block).
BLOCK = 128


def noise_from_uniforms(noise: MeasurementNoise, uniforms: FloatArray) -> FloatArray:
    """State errors ``[dx, dy, dpsi, du, dv, dr]`` (m, m, rad, m/s, m/s, rad/s) from uniforms.

    The errors lie inside the bounds of ``noise`` (module note); the velocity error is in the
    body frame, the position error inertial.

    Parameters
    ----------
    noise : MeasurementNoise
        Bounds of the measurement errors.
    uniforms : ndarray, shape (..., 6)
        Draws in ``[0, 1)``: position radius and direction, velocity radius and direction,
        heading, yaw rate.
    """
    u = np.asarray(uniforms, dtype=float)
    tau = 2.0 * np.pi
    pos, pang = noise.position * np.sqrt(u[..., 0]), tau * u[..., 1]
    vel, vang = noise.velocity * np.sqrt(u[..., 2]), tau * u[..., 3]
    return stack_last(
        [
            pos * np.cos(pang),
            pos * np.sin(pang),
            noise.heading * (2.0 * u[..., 4] - 1.0),
            vel * np.cos(vang),
            vel * np.sin(vang),
            noise.yaw_rate * (2.0 * u[..., 5] - 1.0),
        ]
    )


def noise_generator(seed: int, vehicle: int) -> np.random.Generator:
    """The generator of vehicle ``vehicle``'s measurement noise in the run of ``seed``.

    Parameters
    ----------
    seed : int
        Seed of the run.
    vehicle : int
        Index of the vehicle in the fleet.
    """
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(NOISE_STREAM, int(vehicle))))


def delay_generator(seed: int) -> np.random.Generator:
    """The generator of the varying delays of the run of ``seed``.

    Parameters
    ----------
    seed : int
        Seed of the run.
    """
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(DELAY_STREAM,)))


class ImplementationDraws:
    """Noise and delays of ``S`` runs of ``N`` vehicles, sample after sample.

    Parameters
    ----------
    implementation : Implementation
    seeds : sequence of int
        One seed per run (``S``).
    n : int
        Vehicles per run.
    """

    def __init__(self, implementation: Implementation, seeds: Sequence[int], n: int) -> None:
        self._impl = implementation
        self._s, self._n = len(seeds), int(n)
        exact = implementation.noise.exact
        self._noise_gens = [] if exact else [noise_generator(s, i) for s in seeds for i in range(n)]
        self._delay_gens = [delay_generator(s) for s in seeds] if implementation.varying_delay else []
        self._noise: FloatArray = np.zeros((0, self._s, self._n, 6))
        self._noise_start = 0
        self._delays: FloatArray = np.zeros((self._s, 0))
        self._delay_start = 0

    def noise(self, k: int) -> FloatArray:
        """Measurement errors of sample ``k``, shape ``(S, N, 6)``; ``k`` may not decrease between calls.

        Parameters
        ----------
        k : int
            Sample index, advancing by at most one between calls.
        """
        if self._impl.noise.exact:
            return np.zeros((self._s, self._n, 6))
        if k >= self._noise_start + self._noise.shape[0]:
            self._noise_start = k
            draws = np.stack([g.random((BLOCK, 6)) for g in self._noise_gens])  # (S N, BLOCK, 6)
            draws = draws.reshape(self._s, self._n, BLOCK, 6).transpose(2, 0, 1, 3)
            self._noise = noise_from_uniforms(self._impl.noise, draws)
            # a later block starts where this one ends: k only ever advances by one
        out: FloatArray = self._noise[k - self._noise_start]
        return out

    def delays(self, lo: int, hi: int) -> FloatArray:
        """Delays ``d_k`` (s) of samples ``lo .. hi - 1``, shape ``(S, hi - lo)``; ``lo`` may not decrease.

        Parameters
        ----------
        lo, hi : int
            First sample index and one past the last.
        """
        delay = self._impl.delay
        if not self._impl.varying_delay:
            return np.full((self._s, hi - lo), delay)
        end = self._delay_start + self._delays.shape[1]
        if hi > end:  # keep what is still needed, draw the next blocks of every run's stream
            more = -(-(hi - end) // BLOCK) * BLOCK
            fresh = np.stack([g.random(more) for g in self._delay_gens]) * delay
            self._delays = np.concatenate([self._delays[:, max(lo - self._delay_start, 0) :], fresh], axis=1)
            self._delay_start = max(lo, self._delay_start)
        out: FloatArray = self._delays[:, lo - self._delay_start : hi - self._delay_start]
        return out


__all__ = ["BLOCK", "ImplementationDraws", "delay_generator", "noise_from_uniforms", "noise_generator"]
