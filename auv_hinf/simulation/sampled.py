"""The controller as implemented: law at the sample instants, held forces, delay, noisy measurements.

The convention is :mod:`auv_hinf.models.implementation`'s: at ``t_k = k h`` the law is
evaluated on the state measured at ``s_k = max(t_k - d_k, 0)`` plus the noise of sample ``k``
(:mod:`auv_hinf.simulation.draws`), against the desired motion at ``s_k``, and its forces
(saturated, if actuators are declared) are held on ``[t_k, t_{k+1})``. The plant stays
continuous; :mod:`auv_hinf.simulation.sampled_loop` says how it is integrated.
"""

from __future__ import annotations

import math
from dataclasses import replace

from auv_hinf.exceptions import ParameterError
from auv_hinf.simulation.integrators import SampleSink
from auv_hinf.simulation.results import SimulationResult, build_results
from auv_hinf.simulation.sampled_loop import SampledLoop, SampledSolution
from auv_hinf.simulation.scenario import ScenarioBatch


def integrate_sampled(batch: ScenarioBatch, *, sink: SampleSink | None = None, trace: bool = False) -> SampledSolution:
    """Integrate the scenarios of ``batch`` under their (shared) sampled implementation.

    Parameters
    ----------
    batch : ScenarioBatch
        Each scenario's ``seed`` gives its noise and delay draws.
    sink : callable, optional
        Receives the output samples instead of storing them
        (:data:`~auv_hinf.simulation.integrators.SampleSink`).
    trace : bool
        Also return what the controller did at every sample (:class:`SampleTrace`).

    Raises
    ------
    ParameterError
        If the implementation is the continuous, exact law (that runs in
        :mod:`auv_hinf.simulation.engine`).
    """
    impl = batch.scenarios[0].implementation
    if impl.continuous:
        raise ParameterError("the implementation is continuous and exact: simulate it with the continuous engine")
    loop = SampledLoop(batch, sink, trace)
    loop.start()
    for k in range(loop.k_count):
        loop.interval(k)
    return loop.solution()


def simulate_sampled_batch(batch: ScenarioBatch) -> list[SimulationResult]:
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


__all__ = ["integrate_sampled", "simulate_sampled_batch"]
