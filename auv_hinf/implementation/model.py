"""The controller as it runs: sample time, zero-order hold, delay and measurement noise.

The convention that the certificate and the simulation share (docs/derivations/implementation.md):
at the sample instants ``t_k = k h`` the controller evaluates the continuous law on the
measurement of the state taken at ``s_k = max(t_k - d_k, 0)`` (against the reference at
``s_k``), and holds the resulting forces on ``[t_k, t_{k+1})``. ``d_k`` is the lumped input +
measurement delay: ``delay`` for every sample, or, with ``varying_delay``, any value in
``[0, delay]``. Each measurement is off by at most the :class:`MeasurementNoise` bounds.
So the forces applied at time ``t`` are the law at the earlier time ``t - eta(t)`` with
``0 <= eta(t) <= h + delay`` (:attr:`Implementation.max_lag`), plus the noise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from auv_hinf.exceptions import ParameterError

#: Shortest control period a configuration may declare (s): 1 kHz, above any AUV's control loop
#: and the finest period the sampled simulation runs (a run costs about 1 ms per period).
MIN_SAMPLE_TIME = 1e-3


def _check_nonnegative(name: str, value: float, unit: str) -> float:
    v = float(value)
    if not (v >= 0.0 and v < float("inf")):
        raise ParameterError(f"{name} must be a finite number >= 0 ({unit}), got {value!r}")
    return v


@dataclass(frozen=True)
class MeasurementNoise:
    """Bounds of the measurement errors the controller acts on (all ``>= 0``; zero: exact).

    Attributes
    ----------
    position : float
        Bound of ``|p_measured - p|``, horizontal position (m, Euclidean norm).
    velocity : float
        Bound of ``|(u, v)_measured - (u, v)|``, body-frame velocity (m/s, Euclidean norm).
    heading : float
        Bound of ``|psi_measured - psi|`` (rad).
    yaw_rate : float
        Bound of ``|r_measured - r|`` (rad/s).
    """

    position: float = 0.0
    velocity: float = 0.0
    heading: float = 0.0
    yaw_rate: float = 0.0

    def __post_init__(self) -> None:
        for name, unit in (("position", "m"), ("velocity", "m/s"), ("heading", "rad"), ("yaw_rate", "rad/s")):
            object.__setattr__(self, name, _check_nonnegative(f"noise.{name}", getattr(self, name), unit))

    @property
    def exact(self) -> bool:
        """True when every bound is zero (exact measurements)."""
        return not any((self.position, self.velocity, self.heading, self.yaw_rate))

    def to_dict(self) -> dict[str, float]:
        """JSON-safe dictionary (m, m/s, rad, rad/s)."""
        return asdict(self)

    def scaled(self, scale: float) -> MeasurementNoise:
        """Every bound times ``scale >= 0`` (0: exact measurements).

        Parameters
        ----------
        scale : float
            The factor (dimensionless).
        """
        return MeasurementNoise(
            self.position * scale, self.velocity * scale, self.heading * scale, self.yaw_rate * scale
        )


@dataclass(frozen=True)
class Implementation:
    """How the controller runs: ``sample_time`` (s, ZOH; 0 = continuous), ``delay`` (s), noise.

    Attributes
    ----------
    sample_time : float
        Control period ``h`` (s); the forces are held between samples. ``0``: continuous law.
    delay : float
        Lumped input + measurement delay (s).
    varying_delay : bool
        ``False``: every sample is late by exactly ``delay``; ``True``: by any value in
        ``[0, delay]`` (the certificate covers both).
    noise : MeasurementNoise
        Bounds of the measurement errors.
    """

    sample_time: float = 0.0
    delay: float = 0.0
    varying_delay: bool = False
    noise: MeasurementNoise = field(default_factory=MeasurementNoise)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sample_time", _check_nonnegative("sample_time", self.sample_time, "s"))
        object.__setattr__(self, "delay", _check_nonnegative("delay", self.delay, "s"))
        if not isinstance(self.noise, MeasurementNoise):
            raise ParameterError(f"noise must be a MeasurementNoise, got {self.noise!r}")
        if not isinstance(self.varying_delay, bool):
            raise ParameterError(f"varying_delay must be a bool, got {self.varying_delay!r}")

    @property
    def max_lag(self) -> float:
        """Largest age ``h + delay`` (s) of the measurement behind the force applied at any time."""
        return self.sample_time + self.delay

    @property
    def continuous(self) -> bool:
        """True for the paper's controller: continuous, undelayed, exact measurements."""
        return self.max_lag == 0.0 and self.noise.exact

    @property
    def sampled(self) -> bool:
        """True when the law runs at a sample time (``sample_time > 0``)."""
        return self.sample_time > 0.0

    def describe(self) -> str:
        """One line for reports, e.g. ``10 Hz (0.1 s ZOH), delay 0.1 s, noise ...``."""
        if self.continuous:
            return "continuous law, undelayed, exact measurements (the paper's assumption)"
        rate = f"{1.0 / self.sample_time:.3g} Hz ({self.sample_time:.3g} s ZOH)" if self.sampled else "continuous"
        lag = f"delay {'up to ' if self.varying_delay else ''}{self.delay:.3g} s"
        n = self.noise
        noise = (
            "exact measurements"
            if n.exact
            else f"noise <= {n.position:.3g} m, {n.velocity:.3g} m/s, {n.heading:.3g} rad, {n.yaw_rate:.3g} rad/s"
        )
        return f"{rate}, {lag}, {noise}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (s, s, bool, noise bounds)."""
        return {
            "sample_time": self.sample_time,
            "delay": self.delay,
            "varying_delay": self.varying_delay,
            "noise": self.noise.to_dict(),
        }


__all__ = ["MIN_SAMPLE_TIME", "Implementation", "MeasurementNoise"]
