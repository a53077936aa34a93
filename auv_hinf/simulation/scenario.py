"""What one simulation is: the :class:`Scenario`, and a batch of them with stacked plants.

:class:`ScenarioBatch` stacks the scenarios' initial states, currents and plant
coefficients (:class:`PlantBatch`) so that :mod:`auv_hinf.simulation.engine` integrates them as one
vectorised system.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import cast

import numpy as np

from auv_hinf._typing import FORMATION_FRAMES, NOISE_PATTERNS, FloatArray, FormationFrame, JacobiKind, NoisePattern
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.implementation.model import Implementation
from auv_hinf.law.formation_law import MotionSource, VehicleLaw
from auv_hinf.mission.fleet import FleetReference, PathFrameReference
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import PlantBatch, VehicleParams


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
        for a shaped :class:`~auv_hinf.mission.fleet.FleetReference`, the same reference without
        its shaping; otherwise ``reference`` itself.
    jacobi : {"paper", "orthonormal"}
        Jacobi convention of the reported shape error.
    frame : {"inertial", "path"} or None
        Frame of the reported shape-error components (along/cross track in the path frame);
        default: the frame of a :class:`~auv_hinf.mission.fleet.FleetReference` or
        ``"path"`` for a :class:`~auv_hinf.mission.fleet.PathFrameReference`, else inertial.
    implementation : Implementation
        How the controller runs (sample time, delay, noise). The default is the continuous,
        exact law; any other runs in :mod:`auv_hinf.implementation.sampled_loop`.
    seed : int
        Seed of the run's noise and delay draws (:mod:`auv_hinf.implementation.draws`, >= 0).
    noise_pattern : {"uniform", "bang-bang", "bias", "slow", "against-error"}
        How the run's measurement errors are drawn within their bounds.
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
    noise_pattern: NoisePattern = "uniform"

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
        if self.noise_pattern not in NOISE_PATTERNS:
            raise ParameterError(f"noise_pattern must be one of {NOISE_PATTERNS}, got {self.noise_pattern!r}")
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


__all__ = ["Scenario", "ScenarioBatch"]
