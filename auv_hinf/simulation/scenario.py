"""What one simulation is: the :class:`Scenario`, and a batch of them with stacked plants.

:class:`ScenarioBatch` stacks the scenarios' initial states, currents and plant
coefficients (:class:`PlantBatch`) so that :mod:`auv_hinf.simulation.engine` integrates them as one
vectorised system.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FORMATION_FRAMES, FloatArray, FormationFrame, JacobiKind
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.implementation import Implementation
from auv_hinf.models.path_frame import PathFrameReference
from auv_hinf.models.reference import FleetReference
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.simulation.law import MotionSource, VehicleLaw

_COEFFS = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")


@dataclass(frozen=True)
class Scenario:
    """A closed-loop simulation set-up.

    Attributes
    ----------
    law : VehicleLaw
        The controller (its ``params`` are the controller's model).
    reference : MotionSource
        Desired motion the law tracks.
    plant : VehicleParams
        The simulated vehicles (differs from ``law.params`` for a mismatch study).
    initial : ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` per vehicle (m, m, rad, m/s, m/s, rad/s).
    horizon : float
        Simulated time, s.
    current : tuple of float
        Constant ocean current, inertial frame, m/s.
    envelope : Envelope, optional
        Certified envelope to check the trajectory against.
    samples : int
        Number of output samples (>= 2), equally spaced on ``[0, horizon]``.
    name : str
    mission : MotionSource, optional
        The unshaped mission reference for the formation and position errors. Default:
        for a shaped :class:`~auv_hinf.models.reference.FleetReference`, the same reference without
        its shaping; otherwise ``reference`` itself.
    jacobi : {"paper", "orthonormal"}
        Jacobi convention of the reported shape error.
    frame : {"inertial", "path"} or None
        Frame of the reported shape-error components (along/cross track in the path frame);
        default: the frame of a :class:`~auv_hinf.models.reference.FleetReference` or
        ``"path"`` for a :class:`~auv_hinf.models.path_frame.PathFrameReference`, else inertial.
    implementation : Implementation
        How the controller runs (sample time, delay, noise). The default is the continuous,
        exact law; any other runs in :mod:`auv_hinf.simulation.sampled`.
    seed : int
        Seed of the run's noise and delay draws (:mod:`auv_hinf.simulation.draws`, >= 0).
    """

    law: VehicleLaw
    reference: MotionSource
    plant: VehicleParams
    initial: FloatArray
    horizon: float
    current: tuple[float, float] = (0.0, 0.0)
    envelope: Envelope | None = None
    samples: int = 3001
    name: str = "scenario"
    mission: MotionSource | None = None
    jacobi: JacobiKind = "paper"
    frame: FormationFrame | None = None
    implementation: Implementation = field(default_factory=Implementation)
    seed: int = 0

    def __post_init__(self) -> None:
        init = np.asarray(self.initial, dtype=float)
        ref = self.reference
        n = ref.offsets.shape[0] if isinstance(ref, FleetReference) else np.shape(ref.motion(0.0).p)[0]
        if init.shape != (n, 6) or not np.all(np.isfinite(init)):
            raise ParameterError(f"initial states must be a finite ({n}, 6) array, got shape {init.shape}")
        if not np.isfinite(self.horizon) or self.horizon <= 0:
            raise ParameterError(f"horizon must be > 0 s, got {self.horizon!r}")
        if isinstance(self.samples, bool) or not isinstance(self.samples, (int, np.integer)) or self.samples < 2:
            raise ParameterError(f"samples must be an integer >= 2, got {self.samples!r}")
        cur = tuple(require_finite("current", c) for c in self.current)
        if len(cur) != 2:
            raise ParameterError(f"current must be a pair (m/s), got {self.current!r}")
        if not isinstance(self.implementation, Implementation):
            raise ParameterError(f"implementation must be an Implementation, got {self.implementation!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        object.__setattr__(self, "initial", init)
        object.__setattr__(self, "current", cur)
        if self.frame is None:
            path = isinstance(ref, PathFrameReference) or (isinstance(ref, FleetReference) and ref.frame == "path")
            object.__setattr__(self, "frame", "path" if path else "inertial")
        elif self.frame not in FORMATION_FRAMES:
            raise ParameterError(f"frame must be one of {FORMATION_FRAMES}, got {self.frame!r}")
        if self.mission is None and isinstance(ref, FleetReference) and ref.shaping is not None:
            object.__setattr__(self, "mission", ref.unshaped())

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return int(self.initial.shape[0])

    @property
    def times(self) -> FloatArray:
        """Output sample times (s)."""
        return np.linspace(0.0, self.horizon, self.samples)


@dataclass(frozen=True)
class PlantBatch:
    """Plant parameters of ``S`` scenarios: the nine :class:`VehicleParams` coefficients as arrays (S,)."""

    m11: FloatArray
    m22: FloatArray
    m33: FloatArray
    d11_lin: FloatArray
    d11_quad: FloatArray
    d22_lin: FloatArray
    d22_quad: FloatArray
    d33_lin: FloatArray
    d33_quad: FloatArray

    def __post_init__(self) -> None:
        arrays = [np.atleast_1d(np.asarray(getattr(self, k), dtype=float)) for k in _COEFFS]
        if any(a.ndim != 1 or a.shape != arrays[0].shape for a in arrays):
            raise ParameterError("plant coefficients must be 1-D arrays of one common length S")
        for k, a in zip(_COEFFS, arrays):
            object.__setattr__(self, k, a)
        for s in range(len(self)):
            self[s]  # VehicleParams checks signs and finiteness, naming the field

    @classmethod
    def from_params(cls, params: Sequence[VehicleParams]) -> PlantBatch:
        """Stack a list of :class:`VehicleParams`."""
        if len(params) == 0:
            raise ParameterError("a plant batch needs at least one VehicleParams")
        return cls(**{k: np.array([getattr(p, k) for p in params]) for k in _COEFFS})

    def __len__(self) -> int:
        return int(self.m11.shape[0])

    def __getitem__(self, s: int) -> VehicleParams:
        return VehicleParams(**{k: float(getattr(self, k)[s]) for k in _COEFFS}, name=f"plant[{s}]")

    def coefficients(self, trailing: int, rows: NDArray[np.int_] | None = None) -> VehicleParams:
        """Duck-typed parameters with arrays of shape ``(S,) + (1,) * trailing`` for :func:`vehicle.rhs`.

        ``vehicle.rhs`` reads only the nine coefficients and ``damping``, which broadcast.
        ``rows``: only those scenarios (then ``S = rows.size``).
        """
        pick = slice(None) if rows is None else rows
        shape = (-1,) + (1,) * trailing
        return cast(VehicleParams, _Coefficients({k: getattr(self, k)[pick].reshape(shape) for k in _COEFFS}))


class _Coefficients:
    """Array-valued stand-in for :class:`VehicleParams` (see :meth:`PlantBatch.coefficients`)."""

    damping = VehicleParams.damping

    def __init__(self, values: dict[str, FloatArray]) -> None:
        self.__dict__.update(values)


@dataclass(frozen=True)
class ScenarioBatch:
    """``S`` scenarios integrated together as one vectorised system of shape ``(S, N, 6)``.

    All scenarios share the law, horizon, samples, envelope, N and implementation; they may
    differ in plant parameters, initial states, currents, seeds and (through ``reference``)
    desired motion.

    Parameters
    ----------
    scenarios : sequence of Scenario
    reference : MotionSource, optional
        Batched source: ``motion(t)`` with ``t`` of shape (S,) gives row ``s`` for scenario
        ``s``. Default: the scenarios' common reference (it must be one object).

    Attributes
    ----------
    plant : PlantBatch
    initial : ndarray, shape (S, N, 6)
    current : ndarray, shape (S, 2)
        Inertial, m/s.
    """

    scenarios: tuple[Scenario, ...]
    reference: MotionSource | None = None
    plant: PlantBatch = field(init=False)
    initial: FloatArray = field(init=False)
    current: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        scn = tuple(self.scenarios)
        if not scn:
            raise ParameterError("a scenario batch needs at least one scenario")
        first = scn[0]
        for name in ("law", "horizon", "samples", "envelope", "jacobi", "frame", "n", "implementation"):
            if any(getattr(s, name) != getattr(first, name) for s in scn):
                raise ParameterError(f"all scenarios of a batch must share {name!r}")
        if self.reference is None:
            if any(s.reference is not first.reference for s in scn):
                raise ParameterError("scenarios with different references need an explicit batched reference")
            object.__setattr__(self, "reference", first.reference)
        object.__setattr__(self, "scenarios", scn)
        object.__setattr__(self, "plant", PlantBatch.from_params([s.plant for s in scn]))
        object.__setattr__(self, "initial", np.stack([s.initial for s in scn]))
        object.__setattr__(self, "current", np.array([s.current for s in scn]))

    @property
    def source(self) -> MotionSource:
        """The batched reference (never None after construction)."""
        return cast(MotionSource, self.reference)


__all__ = ["PlantBatch", "Scenario", "ScenarioBatch"]
