"""The tables of the conditions a design meets: the true plant, the declared box and current,
the actuators and the controller as it runs.

Part of the TOML format of :mod:`auv_hinf.config.schema` (same strict rules: ``extra="forbid"``,
strict types, units and ranges on every physical field); :class:`~auv_hinf.config.schema.ConfigFile`
assembles them with the formation, envelope, design and simulation tables.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, field_validator, model_validator

from auv_hinf.config.fields import MAX_COORDINATE, PARAMETERS, ActuatorPreset, Pair, _field, _Table


class PlantTable(_Table):
    """``[simulation.plant]``: the true plant as multipliers (> 0) of the controller's parameters."""

    m11: float | None = _field(None, "multiplier of m11", gt=0.0)
    m22: float | None = _field(None, "multiplier of m22", gt=0.0)
    m33: float | None = _field(None, "multiplier of m33", gt=0.0)
    d11_lin: float | None = _field(None, "multiplier of d11_lin", gt=0.0)
    d11_quad: float | None = _field(None, "multiplier of d11_quad", gt=0.0)
    d22_lin: float | None = _field(None, "multiplier of d22_lin", gt=0.0)
    d22_quad: float | None = _field(None, "multiplier of d22_quad", gt=0.0)
    d33_lin: float | None = _field(None, "multiplier of d33_lin", gt=0.0)
    d33_quad: float | None = _field(None, "multiplier of d33_quad", gt=0.0)


class UncertaintyTable(_Table):
    """``[uncertainty]``: declared box of relative multipliers ``[lo, hi]``, 0 < lo <= 1 <= hi."""

    m11: Pair | None = _field(None, "relative range [lo, hi] of m11")
    m22: Pair | None = _field(None, "relative range [lo, hi] of m22")
    m33: Pair | None = _field(None, "relative range [lo, hi] of m33")
    d11_lin: Pair | None = _field(None, "relative range [lo, hi] of d11_lin")
    d11_quad: Pair | None = _field(None, "relative range [lo, hi] of d11_quad")
    d22_lin: Pair | None = _field(None, "relative range [lo, hi] of d22_lin")
    d22_quad: Pair | None = _field(None, "relative range [lo, hi] of d22_quad")
    d33_lin: Pair | None = _field(None, "relative range [lo, hi] of d33_lin")
    d33_quad: Pair | None = _field(None, "relative range [lo, hi] of d33_quad")

    @field_validator(*PARAMETERS)
    @classmethod
    def _box(cls, value: list[float] | None, info: Any) -> list[float] | None:
        if value is not None and not (0.0 < value[0] <= 1.0 <= value[1]):
            raise ValueError(f"a relative range [lo, hi] must satisfy 0 < lo <= 1 <= hi, got {value}")
        return value


class ActuatorsTable(_Table):
    """``[actuators]``: what the vehicle can push; the certificate checks the law's peak force against it."""

    preset: ActuatorPreset | None = _field(None, "published limits of a vehicle preset (see docs/vehicles.md)")
    tau_x: float | None = _field(None, "largest surge force", "N", gt=0.0, examples=[86.0])
    tau_y: float | None = _field(None, "largest sway force", "N", gt=0.0, examples=[86.0])
    tau_psi: float | None = _field(None, "largest yaw moment", "N m", gt=0.0, examples=[23.0])

    @model_validator(mode="after")
    def _one_source(self) -> ActuatorsTable:
        given = [k for k in ("tau_x", "tau_y", "tau_psi") if getattr(self, k) is not None]
        if self.preset is not None and given:
            raise ValueError(f"give either preset or the limits, not both (got preset and {', '.join(given)})")
        if self.preset is None and len(given) != 3:
            raise ValueError("give all three limits tau_x, tau_y, tau_psi (N, N, N m), or a preset")
        return self


class NoiseTable(_Table):
    """``[implementation.noise]``: bounds of the measurement errors (default: exact)."""

    position: float = _field(0.0, "bound of the horizontal position error (Euclidean)", "m", ge=0.0, le=MAX_COORDINATE)
    velocity: float = _field(0.0, "bound of the body-velocity error |(u, v)| (Euclidean)", "m/s", ge=0.0, le=100.0)
    heading: float = _field(0.0, "bound of the heading error", "rad", ge=0.0, le=3.14159)
    yaw_rate: float = _field(0.0, "bound of the yaw-rate error", "rad/s", ge=0.0, le=100.0)


class ImplementationTable(_Table):
    """``[implementation]``: the controller as it runs (default: continuous, undelayed, exact)."""

    sample_time: float = _field(
        0.0, "control period, forces held between samples (0: continuous)", "s", ge=0.0, le=60.0
    )
    delay: float = _field(0.0, "lumped input + measurement delay", "s", ge=0.0, le=60.0)
    varying_delay: bool = _field(False, "false: every sample late by exactly delay; true: by any value in [0, delay]")
    noise: NoiseTable = Field(default_factory=NoiseTable, description="bounds of the measurement errors")


class DisturbanceTable(_Table):
    """``[disturbance]``: declared bounds of the ocean current."""

    current_speed: float | None = _field(None, "bound on |current|", "m/s", ge=0.0)
    current_rate: float | None = _field(None, "bound on |d current / dt|", "m/s^2", ge=0.0)


__all__ = ["ActuatorsTable", "DisturbanceTable", "ImplementationTable", "NoiseTable", "PlantTable", "UncertaintyTable"]
