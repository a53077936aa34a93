"""Closed-loop simulation of N vehicles under the per-vehicle law, one scenario or a batch.

The closed loop costs O(N) per right-hand-side call. A batch of ``S`` scenarios is one
vectorised system of shape ``(S, N, 6)``; the integrator treats each scenario (or, for
the decoupled fleet, each vehicle) as an independent system with its own step size.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Literal, cast

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_count, require_positive
from auv_hinf.implementation.sampled_loop import integrate_sampled
from auv_hinf.law.formation_law import VehicleLaw, VehicleMotionSource
from auv_hinf.mission.fleet import Motion
from auv_hinf.models.envelope import envelope_bound, envelope_event, envelope_margin
from auv_hinf.models.vehicle import VehicleParams, ground_velocity, plant_derivative
from auv_hinf.numerics.integrators import ATOL, RTOL, BatchSolution, EventFn, SampleSink, dopri5, rk45_reference
from auv_hinf.simulation.results import SimulationResult, build_results
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch

Method = Literal["dopri", "rk45"]
Systems = Literal["scenario", "vehicle"]


def fleet_derivative(
    law: VehicleLaw, plant: VehicleParams, current: FloatArray, states: FloatArray, motion: Motion
) -> FloatArray:
    """Closed-loop ``d/dt`` of states ``(..., N, law.width)``; ``current`` broadcasts to ``(..., N, 2)`` (m/s).

    With integral action the last two columns are the integrator ``z`` (m s), ``z' = p - p_d``.

    Parameters
    ----------
    law : VehicleLaw
        The law (its model, gains and actuators).
    plant : VehicleParams
        The plant, or array-valued coefficients (:meth:`~auv_hinf.models.vehicle.PlantBatch.coefficients`).
    current : ndarray
        Water current (m/s, inertial frame); broadcasts to ``(..., N, 2)``.
    states : ndarray, shape (..., N, law.width)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s), then ``z`` with integral action.
    motion : Motion
        Desired motion, broadcastable to the same leading shape.
    """
    cs = (np.cos(states[..., 2]), np.sin(states[..., 2]))  # shared by the law and the plant
    p_dot = ground_velocity(states, current, cs)
    plant_states = states[..., :6]
    d = plant_derivative(plant, current, plant_states, law.forces(states, p_dot, motion, cs), cs, p_dot)
    if states.shape[-1] == 6:
        return d
    return np.concatenate([d, plant_states[..., 0:2] - motion.p], axis=-1)


def initial_with_controller(law: VehicleLaw, initial: FloatArray) -> FloatArray:
    """Plant states ``(..., N, 6)`` followed by the controller's: the integrator starts at zero.

    Parameters
    ----------
    law : VehicleLaw
        The law; its ``width`` sets the number of controller states.
    initial : ndarray, shape (..., N, 6)
        Initial plant states.
    """
    pad = np.zeros((*initial.shape[:-1], law.width - 6))
    return np.concatenate([initial, pad], axis=-1)


def closed_loop_rhs(scn: Scenario, t: float, y: FloatArray) -> FloatArray:
    """Time derivative of the flat state ``y`` (``law.width N``,) of one scenario at time ``t`` (s).

    Parameters
    ----------
    scn : Scenario
        The scenario (law, plant, current, reference).
    t : float
        Time (s).
    y : ndarray, shape (law.width N,)
        Flat closed-loop state, vehicle after vehicle.
    """
    s = np.asarray(y, dtype=float).reshape(-1, scn.law.width)
    return fleet_derivative(scn.law, scn.plant, np.asarray(scn.current), s, scn.reference.motion(t)).ravel()


def batch_system(
    batch: ScenarioBatch, systems: Systems = "scenario"
) -> tuple[Callable[[FloatArray, FloatArray], FloatArray], EventFn | None]:
    """Batched rhs ``(t (B,), y (B, d)) -> (B, d)`` and envelope event of ``batch``.

    ``systems="scenario"``: ``B = S``, ``d = w N``. ``systems="vehicle"``: ``B = S N``,
    ``d = w``, with ``w`` the law's :attr:`~auv_hinf.law.formation_law.VehicleLaw.width`; each
    vehicle with its own time (the law has no shared state, so the fleet is decoupled); needs a
    :class:`VehicleMotionSource`.

    Parameters
    ----------
    batch : ScenarioBatch
        The scenarios (their first gives the law and the envelope).
    systems : {"scenario", "vehicle"}
        What one system of the batch is.
    """
    n_s, n = batch.initial.shape[:2]
    law, ref, env = batch.scenarios[0].law, batch.source, batch.scenarios[0].envelope
    wd = law.width
    plant = batch.plant.coefficients(1)
    current = np.asfortranarray(batch.current)[:, None, :]
    if systems == "vehicle":
        if not isinstance(ref, VehicleMotionSource):
            raise ParameterError("per-vehicle systems need a reference with motion_per_vehicle(t)")
        vref = ref

        def f_vehicle(t: FloatArray, y: FloatArray) -> FloatArray:
            s = y.reshape(n_s, n, wd)
            return fleet_derivative(law, plant, current, s, vref.motion_per_vehicle(t.reshape(n_s, n))).reshape(-1, wd)

        ev_v = None if env is None else (lambda t, y: envelope_margin(env, y))
        return f_vehicle, ev_v
    if systems != "scenario":
        raise ParameterError(f"systems must be 'scenario' or 'vehicle', got {systems!r}")

    def f_scenario(t: FloatArray, y: FloatArray) -> FloatArray:
        states = np.asfortranarray(y.reshape(n_s, n, wd))  # scenario axis fastest: see auv_hinf.numerics.arrays
        return fleet_derivative(law, plant, current, states, ref.motion(t)).reshape(n_s, -1)

    return f_scenario, (None if env is None else envelope_event(env, n, wd))


def integrate_batch(
    batch: ScenarioBatch,
    *,
    method: Method = "dopri",
    systems: Systems = "scenario",
    rtol: float = RTOL,
    atol: float = ATOL,
    subdivisions: int = 8,
    sink: SampleSink | None = None,
) -> BatchSolution:
    """Integrate all scenarios of ``batch`` together, without post-processing.

    Parameters
    ----------
    batch : ScenarioBatch
        The scenarios; they share the law, the horizon and the output times of the first.
    method : {"dopri", "rk45"}
        ``"dopri"``: vectorised Dormand-Prince with per-system step control
        (:func:`~auv_hinf.numerics.integrators.dopri5`); ``"rk45"``: scipy ``solve_ivp`` per
        scenario (the reference; scenario systems only).
    systems : {"scenario", "vehicle"}
        What one independently step-controlled system is.
    rtol, atol : float
        Tolerances (default :data:`~auv_hinf.numerics.integrators.RTOL`, ``ATOL``).
    subdivisions : int
        Sub-grid points per step on which the envelope margin is checked before brentq.
    sink : callable, optional
        Receives the output samples instead of storing them (``"dopri"`` only; see
        :data:`~auv_hinf.numerics.integrators.SampleSink`); the solution's ``y`` is then None.

    Returns
    -------
    BatchSolution
        ``y`` of shape ``(T, S, w N)`` for scenario systems, ``(T, S N, w)`` for vehicle systems
        (``w = law.width``: 6, or 8 with the integrator).
    """
    rtol, atol = require_positive("rtol", rtol), require_positive("atol", atol)
    subdivisions = require_count("subdivisions (sub-grid points per step)", subdivisions)
    first = batch.scenarios[0]
    n_s, n = batch.initial.shape[:2]
    wd = first.law.width
    initial = initial_with_controller(first.law, batch.initial)
    span = (0.0, float(first.horizon))
    if method == "rk45" and systems == "scenario" and sink is None:
        singles = [ScenarioBatch((scn,)) for scn in batch.scenarios] if n_s > 1 else [batch]
        parts = []
        for one in singles:
            f1, ev1 = batch_system(one, "scenario")
            parts.append(
                rk45_reference(
                    f1,
                    span,
                    initial_with_controller(first.law, one.initial).reshape(1, wd * n),
                    first.times,
                    rtol=rtol,
                    atol=atol,
                    event=ev1,
                )
            )
        return BatchSolution(
            t=first.times,
            y=np.concatenate([cast(FloatArray, p.y) for p in parts], axis=1),
            event_time=np.concatenate([p.event_time for p in parts]),
            n_steps=np.concatenate([p.n_steps for p in parts]),
            n_rejected=np.concatenate([p.n_rejected for p in parts]),
        )
    if method != "dopri":
        raise ParameterError(
            f"method must be 'dopri', or 'rk45' with scenario systems and no sink, got {method!r}/{systems!r}"
        )
    f, event = batch_system(batch, systems)
    y0 = initial.reshape(n_s * n, wd) if systems == "vehicle" else initial.reshape(n_s, wd * n)
    screen = None if first.envelope is None else envelope_bound(first.envelope, 1 if systems == "vehicle" else n, wd)
    return dopri5(
        f,
        span,
        y0,
        first.times,
        rtol=rtol,
        atol=atol,
        event=event,
        subdivisions=subdivisions,
        event_bound=screen,
        sink=sink,
    )


def first_exits(sol: BatchSolution, n_scenarios: int) -> list[float | None]:
    """Each scenario's first envelope exit (s) over its systems, None if it stayed in.

    Parameters
    ----------
    sol : BatchSolution
        Solution of :func:`integrate_batch`; its systems are grouped scenario by scenario.
    n_scenarios : int
        Number of scenarios ``S``.
    """
    exits = sol.event_time.reshape(n_scenarios, -1)
    return [float(e[~np.isnan(e)].min()) if np.any(~np.isnan(e)) else None for e in exits]


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

    The integration is :func:`integrate_batch` (same parameters); every result holds the
    samples and the metrics of :class:`~auv_hinf.simulation.results.SimulationResult`.
    A batch whose implementation is not the continuous, exact law runs sampled instead
    (:func:`~auv_hinf.implementation.sampled_loop.integrate_sampled`: the integration parameters
    do not apply, its scheme is its own).

    Parameters
    ----------
    batch : ScenarioBatch
        The scenarios.
    method : {"dopri", "rk45"}
        Integrator, as in :func:`integrate_batch`.
    systems : {"scenario", "vehicle"}
        What one independently step-controlled system is.
    rtol, atol : float
        Integration tolerances.
    subdivisions : int
        Sub-grid points per step on which the envelope margin is checked.
    """
    if not batch.scenarios[0].implementation.continuous:
        return _sampled_batch(batch)
    sol = integrate_batch(batch, method=method, systems=systems, rtol=rtol, atol=atol, subdivisions=subdivisions)
    n_s, n = batch.initial.shape[:2]
    states = cast(FloatArray, sol.y).reshape(sol.t.size, n_s, n, batch.scenarios[0].law.width)
    steps = sol.n_steps.reshape(n_s, -1).max(axis=1)
    return build_results(batch.scenarios, sol.t, states, first_exits(sol, n_s), [int(x) for x in steps])


def _sampled_batch(batch: ScenarioBatch) -> list[SimulationResult]:
    """Integrate the scenarios of ``batch`` (:func:`integrate_sampled`) and post-process each."""
    sol = integrate_sampled(batch)
    n_s, n = batch.initial.shape[:2]
    assert sol.y is not None and sol.commanded is not None
    states = sol.y.reshape(sol.t.size, n_s, n, 6)
    exits = [None if math.isnan(e) else float(e) for e in sol.event_time]
    results = build_results(
        batch.scenarios,
        sol.t,
        states,
        exits,
        [int(x) for x in sol.n_steps],
        commanded=sol.commanded,
        peaks=sol.commanded_peak,
    )
    gone = sol.diverged
    return [r if math.isnan(g) else replace(r, diverged_at=float(g)) for r, g in zip(results, gone)]


def simulate(
    scn: Scenario,
    *,
    method: Method = "dopri",
    systems: Systems = "scenario",
    rtol: float = RTOL,
    atol: float = ATOL,
    subdivisions: int = 8,
) -> SimulationResult:
    """Integrate one scenario and compute its metrics; see :func:`simulate_batch`.

    Parameters
    ----------
    scn : Scenario
        The scenario.
    method : {"dopri", "rk45"}
        Integrator, as in :func:`integrate_batch`.
    systems : {"scenario", "vehicle"}
        What one independently step-controlled system is.
    rtol, atol : float
        Integration tolerances.
    subdivisions : int
        Sub-grid points per step on which the envelope margin is checked.

    Raises
    ------
    ParameterError
        If ``scn`` is not a :class:`~auv_hinf.simulation.scenario.Scenario`.
    """
    if not isinstance(scn, Scenario):
        raise ParameterError(f"expected a Scenario (plan_run(config).scenario), got {type(scn).__name__}")
    return simulate_batch(
        ScenarioBatch((scn,)), method=method, systems=systems, rtol=rtol, atol=atol, subdivisions=subdivisions
    )[0]


__all__ = [
    "Method",
    "Systems",
    "batch_system",
    "closed_loop_rhs",
    "first_exits",
    "fleet_derivative",
    "initial_with_controller",
    "integrate_batch",
    "simulate",
    "simulate_batch",
]
