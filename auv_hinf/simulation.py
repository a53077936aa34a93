"""Closed-loop simulation of N vehicles under the per-vehicle law, one scenario or a batch.

The closed loop costs O(N) per right-hand-side call. A batch of ``S`` scenarios is one
vectorised system of shape ``(S, N, 6)``; the integrator treats each scenario (or, for
the decoupled fleet, each vehicle) as an independent system with its own step size.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal, cast

import numpy as np

from ._typing import FloatArray, JacobiKind
from .control_law import MotionSource, VehicleLaw, VehicleMotionSource
from .envelope import Envelope
from .exceptions import ParameterError, require_finite
from .integrators import ATOL, RTOL, BatchSolution, EventBound, EventFn, dopri5, rk45_reference
from .postprocess import envelope_margin, ground_velocity
from .reference import FleetReference, Motion
from .results import SimulationResult, build_results
from .vehicle import VehicleParams, rhs

Method = Literal["dopri", "rk45"]
Systems = Literal["scenario", "vehicle"]
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
        for a shaped :class:`~auv_hinf.reference.FleetReference`, the same reference without
        its shaping; otherwise ``reference`` itself.
    jacobi : {"paper", "orthonormal"}
        Jacobi convention of the reported shape error.
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

    def __post_init__(self) -> None:
        init = np.asarray(self.initial, dtype=float)
        n = np.shape(self.reference.motion(0.0).p)[0]
        if init.shape != (n, 6) or not np.all(np.isfinite(init)):
            raise ParameterError(f"initial states must be a finite ({n}, 6) array, got shape {init.shape}")
        if not np.isfinite(self.horizon) or self.horizon <= 0:
            raise ParameterError(f"horizon must be > 0 s, got {self.horizon!r}")
        if isinstance(self.samples, bool) or not isinstance(self.samples, (int, np.integer)) or self.samples < 2:
            raise ParameterError(f"samples must be an integer >= 2, got {self.samples!r}")
        cur = tuple(require_finite("current", c) for c in self.current)
        if len(cur) != 2:
            raise ParameterError(f"current must be a pair (m/s), got {self.current!r}")
        object.__setattr__(self, "initial", init)
        object.__setattr__(self, "current", cur)
        ref = self.reference
        if self.mission is None and isinstance(ref, FleetReference) and ref.shaping is not None:
            object.__setattr__(self, "mission", FleetReference(ref.mission, ref.offsets))

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

    def coefficients(self, trailing: int) -> VehicleParams:
        """Duck-typed parameters with arrays of shape ``(S,) + (1,) * trailing`` for :func:`vehicle.rhs`.

        ``vehicle.rhs`` reads only the nine coefficients and ``damping``, which broadcast.
        """
        shape = (len(self),) + (1,) * trailing
        return cast(VehicleParams, _Coefficients({k: getattr(self, k).reshape(shape) for k in _COEFFS}))


class _Coefficients:
    """Array-valued stand-in for :class:`VehicleParams` (see :meth:`PlantBatch.coefficients`)."""

    damping = VehicleParams.damping

    def __init__(self, values: dict[str, FloatArray]) -> None:
        self.__dict__.update(values)


@dataclass(frozen=True)
class ScenarioBatch:
    """``S`` scenarios integrated together as one vectorised system of shape ``(S, N, 6)``.

    All scenarios share the law, horizon, samples, envelope and N; they may differ in
    plant parameters, initial states, currents and (through ``reference``) desired motion.

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
        for name in ("law", "horizon", "samples", "envelope", "jacobi", "n"):
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


def fleet_derivative(
    law: VehicleLaw, plant: VehicleParams, current: FloatArray, states: FloatArray, motion: Motion
) -> FloatArray:
    """Closed-loop ``d/dt`` of states ``(..., N, 6)``; ``current`` broadcasts to ``(..., N, 2)`` (m/s)."""
    cs = (np.cos(states[..., 2]), np.sin(states[..., 2]))  # shared by the law and the plant
    p_dot = ground_velocity(states, current, cs)
    d = rhs(plant, states, law.forces(states, p_dot, motion, cs), cs)
    d[..., 0:2] = p_dot
    return d


def closed_loop_rhs(scn: Scenario, t: float, y: FloatArray) -> FloatArray:
    """Time derivative of the flat state ``y`` (6N,) of one scenario at time ``t`` (s)."""
    s = np.asarray(y, dtype=float).reshape(-1, 6)
    return fleet_derivative(scn.law, scn.plant, np.asarray(scn.current), s, scn.reference.motion(t)).ravel()


def batch_system(
    batch: ScenarioBatch, systems: Systems = "scenario"
) -> tuple[Callable[[FloatArray, FloatArray], FloatArray], EventFn | None]:
    """Batched rhs ``(t (B,), y (B, d)) -> (B, d)`` and envelope event of ``batch``.

    ``systems="scenario"``: ``B = S``, ``d = 6N``. ``systems="vehicle"``: ``B = S N``,
    ``d = 6``, each vehicle with its own time (the law has no shared state, so the fleet is
    decoupled); needs a :class:`VehicleMotionSource`.
    """
    n_s, n = batch.initial.shape[:2]
    law, ref, env = batch.scenarios[0].law, batch.source, batch.scenarios[0].envelope
    plant = batch.plant.coefficients(1)
    current = batch.current[:, None, :]
    if systems == "vehicle":
        if not isinstance(ref, VehicleMotionSource):
            raise ParameterError("per-vehicle systems need a reference with motion_per_vehicle(t)")
        vref = ref

        def f_vehicle(t: FloatArray, y: FloatArray) -> FloatArray:
            s = y.reshape(n_s, n, 6)
            return fleet_derivative(law, plant, current, s, vref.motion_per_vehicle(t.reshape(n_s, n))).reshape(-1, 6)

        ev_v = None if env is None else (lambda t, y: envelope_margin(env, y))
        return f_vehicle, ev_v
    if systems != "scenario":
        raise ParameterError(f"systems must be 'scenario' or 'vehicle', got {systems!r}")

    def f_scenario(t: FloatArray, y: FloatArray) -> FloatArray:
        return fleet_derivative(law, plant, current, y.reshape(n_s, n, 6), ref.motion(t)).reshape(n_s, -1)

    def ev_scenario(t: FloatArray, y: FloatArray) -> FloatArray:
        assert env is not None
        margin: FloatArray = envelope_margin(env, y.reshape((*y.shape[:-1], n, 6))).min(axis=-1)
        return margin

    return f_scenario, (None if env is None else ev_scenario)


def envelope_bound(envelope: Envelope, n: int) -> EventBound:
    """Sound lower bound of the envelope event over a box of flat states (see ``EventBound``).

    Each margin is one of ``u``, ``v``, ``r`` minus or plus a constant, so over ``|y' - y| <= radius``
    it is at least its value at ``y`` minus that component's radius. ``n`` is the number of
    vehicles per system (1 for vehicle systems).
    """

    def bound(y: FloatArray, radius: FloatArray) -> FloatArray:
        s, rad = y.reshape(*y.shape[:-1], n, 6), radius.reshape(*radius.shape[:-1], n, 6)
        low: FloatArray = (envelope_margin(envelope, s) - rad[..., 3:6].max(axis=-1)).min(axis=-1)
        return low

    return bound


def simulate_batch(
    batch: ScenarioBatch,
    *,
    method: Method = "dopri",
    systems: Systems = "scenario",
    rtol: float = RTOL,
    atol: float = ATOL,
    subdivisions: int = 8,
) -> list[SimulationResult]:
    """Integrate all scenarios of ``batch`` together and post-process each.

    Parameters
    ----------
    method : {"dopri", "rk45"}
        ``"dopri"``: vectorised Dormand-Prince with per-system step control
        (:func:`~auv_hinf.integrators.dopri5`); ``"rk45"``: scipy ``solve_ivp`` per
        scenario (the reference; scenario systems only).
    systems : {"scenario", "vehicle"}
        What one independently step-controlled system is.
    rtol, atol : float
        Tolerances (default :data:`~auv_hinf.integrators.RTOL`, ``ATOL``).
    subdivisions : int
        Sub-grid points per step on which the envelope margin is checked before brentq.
    """
    first = batch.scenarios[0]
    n_s, n = batch.initial.shape[:2]
    span = (0.0, float(first.horizon))
    sol: BatchSolution
    if method == "rk45" and systems == "scenario":
        singles = [ScenarioBatch((scn,)) for scn in batch.scenarios] if n_s > 1 else [batch]
        parts = []
        for one in singles:
            f1, ev1 = batch_system(one, "scenario")
            parts.append(
                rk45_reference(f1, span, one.initial.reshape(1, 6 * n), first.times, rtol=rtol, atol=atol, event=ev1)
            )
        sol = BatchSolution(
            t=first.times,
            y=np.concatenate([p.y for p in parts], axis=1),
            event_time=np.concatenate([p.event_time for p in parts]),
            n_steps=np.concatenate([p.n_steps for p in parts]),
            n_rejected=np.concatenate([p.n_rejected for p in parts]),
        )
    elif method == "dopri":
        f, event = batch_system(batch, systems)
        y0 = batch.initial.reshape(n_s * n, 6) if systems == "vehicle" else batch.initial.reshape(n_s, 6 * n)
        screen = None if first.envelope is None else envelope_bound(first.envelope, 1 if systems == "vehicle" else n)
        sol = dopri5(
            f, span, y0, first.times, rtol=rtol, atol=atol, event=event, subdivisions=subdivisions, event_bound=screen
        )
    else:
        raise ParameterError(f"method must be 'dopri', or 'rk45' with scenario systems, got {method!r}/{systems!r}")
    states = sol.y.reshape(sol.t.size, n_s, n, 6)
    exits = sol.event_time.reshape(n_s, -1)
    steps = sol.n_steps.reshape(n_s, -1).max(axis=1)
    first_exits = [float(e[~np.isnan(e)].min()) if np.any(~np.isnan(e)) else None for e in exits]
    return build_results(batch.scenarios, sol.t, states, first_exits, [int(x) for x in steps])


def simulate(
    scn: Scenario,
    *,
    method: Method = "dopri",
    systems: Systems = "scenario",
    rtol: float = RTOL,
    atol: float = ATOL,
    subdivisions: int = 8,
) -> SimulationResult:
    """Integrate one scenario and compute its metrics; see :func:`simulate_batch`."""
    return simulate_batch(
        ScenarioBatch((scn,)), method=method, systems=systems, rtol=rtol, atol=atol, subdivisions=subdivisions
    )[0]


__all__ = [
    "PlantBatch",
    "Scenario",
    "ScenarioBatch",
    "SimulationResult",
    "batch_system",
    "closed_loop_rhs",
    "fleet_derivative",
    "ground_velocity",
    "simulate",
    "simulate_batch",
]
