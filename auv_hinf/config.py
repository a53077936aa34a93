"""Design configuration: TOML files and built-in presets, validated with clear messages.

TOML layout (every table optional except where noted)::

    [vehicle]            # preset = "paper2011" | "remus100", or the nine parameters
    preset = "paper2011"
    [formation]
    n = 3
    jacobi = "paper"     # or "orthonormal"
    shape = [[0, 10], [20, 0]]        # N-1 Jacobi vectors (m), or
    # polygon_radius = 15.0           # a regular polygon of that radius
    [envelope]
    u = [0, 3.5]
    v = [-1, 1]
    r = [-0.5, 0.5]
    [design]
    method = "stabilizing"   # paper | stabilizing | minimal
    # gamma = 0.5            # default 1/sigma_upper
    # lambda = -2.1          # default: most negative over the envelope
    k1 = 0.5
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .design import GAIN_METHODS
from .envelope import Envelope
from .exceptions import AuvHinfError, ConfigError
from .formation import JacobiTransform, offsets_from_shape, regular_polygon, shape_from_offsets
from .vehicle import VehicleParams, preset

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


@dataclass(frozen=True)
class FormationConfig:
    """Everything needed to certify (and simulate) one formation design.

    Attributes
    ----------
    name : str
        Preset name or file stem.
    vehicle : VehicleParams
    n : int
        Number of vehicles.
    jacobi : str
        ``"paper"`` or ``"orthonormal"``.
    shape : tuple
        Desired Jacobi shape vectors ``rho_d`` (N-1 pairs, m) in the ``jacobi`` convention.
    envelope : Envelope
    method : str
        Gain method used by the certificate.
    gamma : float or None
        Override of ``1/sigma_upper``.
    lam : float or None
        Override of the envelope lambda (1/s).
    k1 : float
        Theorem 2 position gain (1/s^2).
    """

    name: str
    vehicle: VehicleParams
    n: int
    jacobi: str
    shape: tuple[tuple[float, float], ...]
    envelope: Envelope
    method: str = "stabilizing"
    gamma: float | None = None
    lam: float | None = None
    k1: float = 0.5

    @property
    def transform(self) -> JacobiTransform:
        """The Jacobi transform of this configuration."""
        return JacobiTransform(self.n, self.jacobi)  # type: ignore[arg-type]

    def with_method(self, method: str) -> "FormationConfig":
        """Copy with another gain method."""
        if method not in GAIN_METHODS:
            raise ConfigError(f"design.method must be one of {GAIN_METHODS}, got {method!r}")
        return replace(self, method=method)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "name": self.name, "vehicle": self.vehicle.to_dict(), "n": self.n, "jacobi": self.jacobi,
            "shape": [list(s) for s in self.shape], "envelope": self.envelope.to_dict(),
            "method": self.method, "gamma": self.gamma, "lambda": self.lam, "k1": self.k1,
        }


PAPER_ENVELOPE = Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-0.5, 0.5))
HEXAGON_RADIUS = 15.0  # m: the paper gives no size for Fig. 3; chosen here and documented


def _hexagon_shape() -> tuple[tuple[float, float], ...]:
    t = JacobiTransform(6, "paper")
    rho = shape_from_offsets(regular_polygon(6, HEXAGON_RADIUS), t)
    return tuple((float(a), float(b)) for a, b in rho)


def preset_config(name: str) -> FormationConfig:
    """Built-in configurations: ``paper-triangle`` and ``paper-hexagon``."""
    from .vehicle import paper2011

    if name == "paper-triangle":
        return FormationConfig(
            name=name, vehicle=paper2011(), n=3, jacobi="paper",
            shape=((0.0, 10.0), (20.0, 0.0)), envelope=PAPER_ENVELOPE,
        )
    if name == "paper-hexagon":
        return FormationConfig(
            name=name, vehicle=paper2011(), n=6, jacobi="paper", shape=_hexagon_shape(),
            envelope=PAPER_ENVELOPE,
        )
    raise ConfigError(f"unknown preset {name!r}; expected 'paper-triangle' or 'paper-hexagon'")


def _get(table: dict[str, Any], key: str, kind: type | tuple[type, ...], where: str, default: Any = None) -> Any:
    if key not in table:
        return default
    val = table[key]
    if isinstance(val, bool) or not isinstance(val, kind):
        raise ConfigError(f"{where}.{key} has the wrong type: got {val!r}")
    if isinstance(val, float) and not math.isfinite(val):
        raise ConfigError(f"{where}.{key} must be finite, got {val!r}")
    return val


def config_from_dict(data: dict[str, Any], name: str = "config") -> FormationConfig:
    """Build and validate a :class:`FormationConfig` from parsed TOML."""
    known = {"vehicle", "formation", "envelope", "design", "simulation"}
    unknown = set(data) - known
    if unknown:
        raise ConfigError(f"unknown table(s) {sorted(unknown)}; expected some of {sorted(known)}")
    try:
        veh = data.get("vehicle", {"preset": "paper2011"})
        if "preset" in veh:
            vehicle = preset(_get(veh, "preset", str, "vehicle"))
        else:
            fields = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
            missing = [f for f in fields if f not in veh]
            if missing:
                raise ConfigError(f"vehicle: missing keys {missing} (or give vehicle.preset)")
            vehicle = VehicleParams(**{f: veh[f] for f in fields}, name=name)
        form = data.get("formation", {})
        n = _get(form, "n", int, "formation", 3)
        jacobi = _get(form, "jacobi", str, "formation", "paper")
        transform = JacobiTransform(n, jacobi)
        if "shape" in form:
            rho = np.asarray(_get(form, "shape", list, "formation"), dtype=float)
            if rho.shape != (n - 1, 2):
                raise ConfigError(f"formation.shape must be {n - 1} pairs [x, y], got shape {rho.shape}")
        else:
            radius = _get(form, "polygon_radius", (int, float), "formation", 15.0)
            rho = shape_from_offsets(regular_polygon(n, float(radius)), transform)
        if not np.all(np.isfinite(rho)):
            raise ConfigError("formation.shape must be finite")
        offsets_from_shape(rho, transform)
        env = data.get("envelope", {})
        envelope = Envelope(
            u=env.get("u", PAPER_ENVELOPE.u), v=env.get("v", PAPER_ENVELOPE.v),
            r=env.get("r", PAPER_ENVELOPE.r), psi=env.get("psi", PAPER_ENVELOPE.psi),
        )
        des = data.get("design", {})
        method = _get(des, "method", str, "design", "stabilizing")
        if method not in GAIN_METHODS:
            raise ConfigError(f"design.method must be one of {GAIN_METHODS}, got {method!r}")
        gamma = _get(des, "gamma", (int, float), "design")
        if gamma is not None and gamma <= 0:
            raise ConfigError(f"design.gamma must be > 0, got {gamma!r}")
        lam = _get(des, "lambda", (int, float), "design")
        if lam is not None and lam >= 0:
            raise ConfigError(f"design.lambda must be < 0, got {lam!r}")
        k1 = _get(des, "k1", (int, float), "design", 0.5)
        if k1 <= 0:
            raise ConfigError(f"design.k1 must be > 0, got {k1!r}")
    except ConfigError:
        raise
    except AuvHinfError as exc:
        raise ConfigError(str(exc)) from None
    return FormationConfig(
        name=name, vehicle=vehicle, n=n, jacobi=jacobi,
        shape=tuple((float(a), float(b)) for a, b in rho), envelope=envelope, method=method,
        gamma=None if gamma is None else float(gamma), lam=None if lam is None else float(lam), k1=float(k1),
    )


def load_config(path: str | Path) -> FormationConfig:
    """Read and validate a TOML configuration file."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise ConfigError(f"cannot read config {str(p)!r}: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: invalid TOML: {exc}") from None
    return config_from_dict(data, name=p.stem)
