"""Frozen runtime settings of the ``[reference]``, ``[simulation]``, ``[uncertainty]`` and
``[disturbance]`` tables.

Each validates itself at construction with the table's model of :mod:`auv_hinf.config.schema`,
so a bad value raises :class:`~auv_hinf.exceptions.ConfigError` from Python as from TOML.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from auv_hinf.config.conditions import DisturbanceTable, UncertaintyTable
from auv_hinf.config.fields import REFERENCE_MODELS, ReferenceKind, StartKind
from auv_hinf.config.messages import as_dict, plain_data, set_fields, validate_table
from auv_hinf.config.schema import DEFAULT_HORIZON, DEFAULT_SEED, DEFAULT_START, SimulationTable
from auv_hinf.exceptions import ConfigError
from auv_hinf.models.vehicle import VehicleParams


@dataclass(frozen=True)
class ReferenceConfig:
    """Mission reference (the formation centre's path), validated but not built.

    Parameters
    ----------
    kind : {"sine", "line", "circle", "lawnmower"}
    params : tuple of (str, float) pairs, or a dict
        Parameters of that kind (m, m/s, rad, rad/s; see ``auv-hinf schema``); missing
        ones take their defaults, so the stored tuple is complete.
    """

    kind: ReferenceKind = "sine"
    params: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        model = REFERENCE_MODELS.get(self.kind) if isinstance(self.kind, str) else None
        if model is None:
            raise ConfigError(f"reference.kind must be one of {tuple(REFERENCE_MODELS)}, got {self.kind!r}")
        given = plain_data(as_dict(self.params, "reference params"))
        table = validate_table(model, {**given, "kind": self.kind}, ("reference", self.kind))
        set_fields(self, params=tuple((k, float(v)) for k, v in table.model_dump(exclude={"kind"}).items()))

    def kwargs(self) -> dict[str, float]:
        """The parameters as keyword arguments, e.g. for ``reference_from_dict(kind, **kwargs)``."""
        return dict(self.params)

    def to_dict(self) -> dict[str, Any]:
        """``{"kind": ..., **params}``: JSON-safe and a valid ``[reference]`` table."""
        return {"kind": self.kind, **self.kwargs()}


@dataclass(frozen=True)
class SimulationConfig:
    """Closed-loop simulation settings (the ``[simulation]`` table).

    Attributes
    ----------
    horizon : float
        Simulated time, s (> 0).
    start : {"shaped", "paper"}
        ``"shaped"``: the reference blends from the actual start; ``"paper"``: raw reference.
    initial : tuple of tuples or None
        One ``[x, y, psi, u, v, r]`` per vehicle (m, m, rad, m/s, m/s, rad/s); ``None``
        lets the scenario choose.
    current : tuple of float
        Constant ocean current, inertial frame, m/s.
    blend_time : float or None
        Reference blending time, s (``None``: chosen by the certificate).
    plant : tuple of (str, float) pairs
        True plant as multipliers (> 0) of the controller's parameters; a dict is accepted.
    seed : int
        Seed of the noise and delay draws of a sampled implementation (>= 0).
    """

    horizon: float = DEFAULT_HORIZON
    start: StartKind = DEFAULT_START
    initial: tuple[tuple[float, ...], ...] | None = None
    current: tuple[float, float] = (0.0, 0.0)
    blend_time: float | None = None
    plant: tuple[tuple[str, float], ...] = ()
    seed: int = DEFAULT_SEED

    def __post_init__(self) -> None:
        raw = {
            "horizon": self.horizon,
            "start": self.start,
            "current": self.current,
            "plant": as_dict(self.plant, "simulation.plant"),
            "seed": self.seed,
        }
        raw.update({k: getattr(self, k) for k in ("initial", "blend_time") if getattr(self, k) is not None})
        t = validate_table(SimulationTable, plain_data(raw), ("simulation",))
        rows = None if t.initial is None else tuple(tuple(row) for row in t.initial)
        set_fields(
            self,
            horizon=t.horizon,
            start=t.start,
            initial=rows,
            current=tuple(t.current),
            blend_time=t.blend_time,
            plant=tuple((k, v) for k, v in t.plant.model_dump().items() if v is not None),
            seed=t.seed,
        )

    def plant_params(self, nominal: VehicleParams) -> VehicleParams:
        """The simulated plant: ``nominal`` with the :attr:`plant` multipliers applied."""
        if not self.plant:
            return nominal
        scaled = {k: getattr(nominal, k) * m for k, m in self.plant}
        label = ", ".join(f"{k} x{m:g}" for k, m in self.plant)
        return replace(nominal, name=f"{nominal.name} ({label})", **scaled)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary; absent options are ``None``."""
        return {
            "horizon": self.horizon,
            "start": self.start,
            "initial": None if self.initial is None else [list(r) for r in self.initial],
            "current": list(self.current),
            "blend_time": self.blend_time,
            "plant": dict(self.plant),
            "seed": self.seed,
        }


@dataclass(frozen=True)
class UncertaintyConfig:
    """Declared parameter box (``[uncertainty]``): name -> relative ``(lo, hi)``, 0 < lo <= 1 <= hi."""

    box: tuple[tuple[str, tuple[float, float]], ...] = ()

    def __post_init__(self) -> None:
        t = validate_table(UncertaintyTable, plain_data(as_dict(self.box, "uncertainty")), ("uncertainty",))
        set_fields(self, box=tuple((k, (v[0], v[1])) for k, v in t.model_dump().items() if v is not None))

    def to_dict(self) -> dict[str, list[float]]:
        """``{name: [lo, hi]}``: JSON-safe and a valid ``[uncertainty]`` table."""
        return {k: list(v) for k, v in self.box}


@dataclass(frozen=True)
class DisturbanceConfig:
    """Declared current bounds (``[disturbance]``): speed in m/s, rate in m/s^2 (``None``: not declared)."""

    current_speed: float | None = None
    current_rate: float | None = None

    def __post_init__(self) -> None:
        raw = {
            k: v
            for k, v in (("current_speed", self.current_speed), ("current_rate", self.current_rate))
            if v is not None
        }
        t = validate_table(DisturbanceTable, plain_data(raw), ("disturbance",))
        set_fields(self, current_speed=t.current_speed, current_rate=t.current_rate)

    def to_dict(self) -> dict[str, float]:
        """The declared bounds only (a valid ``[disturbance]`` table)."""
        return {
            k: v
            for k, v in (("current_speed", self.current_speed), ("current_rate", self.current_rate))
            if v is not None
        }


__all__ = ["DisturbanceConfig", "ReferenceConfig", "SimulationConfig", "UncertaintyConfig"]
