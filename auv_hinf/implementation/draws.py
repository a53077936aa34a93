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

That is the ``uniform`` pattern. The certificates cover *any* errors within the bounds, and a
run can put them where they hurt (``[simulation] noise_pattern``, :func:`pattern_noise`): every
error at its bound, in a direction drawn once per vehicle from its stream (the first six
uniforms), with a sign that is constant (``bias``), flips every sample (``bang-bang``) or every
:data:`SLOW_HALF_PERIOD` seconds (``slow``); or (``against-error``) opposing each measured error,
so that the law sees less error than there is and under-reacts
(:meth:`ImplementationDraws.against`). A campaign with ``mixed`` gives run ``i`` the pattern
``NOISE_PATTERNS[i mod 5]``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from auv_hinf._typing import NOISE_PATTERNS, FloatArray
from auv_hinf.exceptions import ParameterError
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.numerics.arrays import stack_last

#: First spawn-key word of the noise streams (one per vehicle) and of the delay stream of a run.
NOISE_STREAM, DELAY_STREAM = 1, 2
#: Half the period (s) of the ``slow`` pattern's square wave: slower than the loops' settling, so
#: each switch acts as a step of twice the bound.
SLOW_HALF_PERIOD = 5.0

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


def pattern_sign(pattern: str, k: int, sample_time: float) -> float:
    """The sign of a fixed-direction pattern at sample ``k`` (``bias``, ``bang-bang`` or ``slow``).

    Parameters
    ----------
    pattern : str
        The pattern.
    k : int
        Sample index.
    sample_time : float
        The sample time (s).
    """
    if pattern == "bang-bang":
        return -1.0 if k % 2 else 1.0
    if pattern == "slow":
        half = max(1, round(SLOW_HALF_PERIOD / max(sample_time, 1e-12)))
        return -1.0 if (k // half) % 2 else 1.0
    return 1.0


def pattern_noise(noise: MeasurementNoise, directions: FloatArray, sign: float) -> FloatArray:
    """Errors at their bounds in the drawn ``directions``, times ``sign`` (the fixed-direction patterns).

    Parameters
    ----------
    noise : MeasurementNoise
        The bounds.
    directions : ndarray, shape (..., 4)
        Position angle, velocity angle (rad) and the heading's and yaw rate's signs (+-1).
    sign : float
        +1 or -1.
    """
    d = np.asarray(directions, dtype=float)
    return sign * stack_last(
        [
            noise.position * np.cos(d[..., 0]),
            noise.position * np.sin(d[..., 0]),
            noise.heading * d[..., 2],
            noise.velocity * np.cos(d[..., 1]),
            noise.velocity * np.sin(d[..., 1]),
            noise.yaw_rate * d[..., 3],
        ]
    )


def against_noise(noise: MeasurementNoise, errors: FloatArray) -> FloatArray:
    """Errors at their bounds opposing ``errors`` (position, heading, body velocity, yaw rate).

    Parameters
    ----------
    noise : MeasurementNoise
        The bounds.
    errors : ndarray, shape (..., 6)
        The true errors ``[ex, ey, epsi, eu, ev, er]`` at the measurement (m, rad, m/s body frame,
        rad/s). A zero error is taken as pointing along +x (a vector) or positive (a scalar): the
        pattern then kicks a loop that sits exactly on its slot, instead of leaving it there.
    """
    e = np.asarray(errors, dtype=float)

    def unit(x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        r = np.hypot(x, y)
        safe = np.where(r > 0.0, r, 1.0)
        return np.where(r > 0.0, x / safe, 1.0), np.where(r > 0.0, y / safe, 0.0)

    def sign(x: FloatArray) -> FloatArray:
        out: FloatArray = np.where(x < 0.0, -1.0, 1.0)
        return out

    px, py = unit(e[..., 0], e[..., 1])
    vx, vy = unit(e[..., 3], e[..., 4])
    return -stack_last(
        [
            noise.position * px,
            noise.position * py,
            noise.heading * sign(e[..., 2]),
            noise.velocity * vx,
            noise.velocity * vy,
            noise.yaw_rate * sign(e[..., 5]),
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
    patterns : sequence of str, optional
        One noise pattern per run (default ``uniform``; see the module note).
    """

    def __init__(
        self, implementation: Implementation, seeds: Sequence[int], n: int, patterns: Sequence[str] | None = None
    ) -> None:
        self._impl = implementation
        self._s, self._n = len(seeds), int(n)
        exact = implementation.noise.exact
        self._patterns = list(patterns) if patterns is not None else ["uniform"] * self._s
        if len(self._patterns) != self._s or any(p not in NOISE_PATTERNS for p in self._patterns):
            raise ParameterError(f"one noise pattern of {NOISE_PATTERNS} per run is needed, got {patterns!r}")
        self._noise_gens = [] if exact else [noise_generator(s, i) for s in seeds for i in range(n)]
        self._delay_gens = [delay_generator(s) for s in seeds] if implementation.varying_delay else []
        self._noise: FloatArray = np.zeros((0, self._s, self._n, 6))
        self._noise_start = 0
        self._delays: FloatArray = np.zeros((self._s, 0))
        self._delay_start = 0
        # the fixed-direction patterns' directions: four draws of a generator of each vehicle's stream
        first = np.stack([noise_generator(s, i).random(4) for s in seeds for i in range(n)]).reshape(
            self._s, self._n, 4
        )
        signs = np.where(first[..., 2:] < 0.5, -1.0, 1.0)
        self._directions = np.concatenate([2.0 * np.pi * first[..., :2], signs], axis=-1)

    @property
    def against_rows(self) -> FloatArray:
        """Which runs use the ``against-error`` pattern, shape ``(S,)`` (bool)."""
        return np.array([p == "against-error" for p in self._patterns])

    def against(self, errors: FloatArray) -> FloatArray:
        """The ``against-error`` errors of the runs that use it (zero elsewhere), shape ``(S, N, 6)``.

        Parameters
        ----------
        errors : ndarray, shape (S, N, 6)
            The true errors at the measurement (see :func:`against_noise`).
        """
        out: FloatArray = np.where(self.against_rows[:, None, None], against_noise(self._impl.noise, errors), 0.0)
        return out

    def noise(self, k: int) -> FloatArray:
        """Measurement errors of sample ``k``, shape ``(S, N, 6)``; ``k`` may not decrease between calls.

        Parameters
        ----------
        k : int
            Sample index, advancing by at most one between calls.
        """
        if self._impl.noise.exact:
            return np.zeros((self._s, self._n, 6))
        uniform = self._uniform(k)
        if all(p == "uniform" for p in self._patterns):
            return uniform
        out = np.array(uniform)
        for row, p in enumerate(self._patterns):
            if p in ("bias", "bang-bang", "slow"):
                sign = pattern_sign(p, k, self._impl.sample_time)
                out[row] = pattern_noise(self._impl.noise, self._directions[row], sign)
            elif p == "against-error":
                out[row] = 0.0  # the loop adds :meth:`against` from the errors it measures
        return out

    def _uniform(self, k: int) -> FloatArray:
        """The ``uniform`` draws of sample ``k`` for every run, shape ``(S, N, 6)``."""
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


__all__ = [
    "BLOCK",
    "SLOW_HALF_PERIOD",
    "ImplementationDraws",
    "against_noise",
    "delay_generator",
    "noise_from_uniforms",
    "noise_generator",
    "pattern_noise",
    "pattern_sign",
]
