"""The reference integrator: scipy ``solve_ivp`` (RK45) behind the batch interface of
:func:`~auv_hinf.simulation.integrators.dopri5`, on one system.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, SolverError
from auv_hinf.simulation.integrators import ATOL, RTOL, BatchRhs, BatchSolution, EventFn, check_span


def rk45_reference(
    rhs: BatchRhs,
    t_span: tuple[float, float],
    y0: FloatArray,
    t_eval: FloatArray,
    *,
    rtol: float = RTOL,
    atol: float = ATOL,
    event: EventFn | None = None,
) -> BatchSolution:
    """scipy ``solve_ivp`` (RK45) on one system (``B = 1``); same interface as :func:`dopri5`.

    The reference the vectorised integrator is tested against. Events use scipy's own
    location (sign changes between step end points, then a root search on its dense
    output), so an excursion inside one step is missed.

    Raises
    ------
    ParameterError
        If ``y0`` holds more than one system.
    SolverError
        If ``solve_ivp`` reports a failure.
    """
    y, te = check_span(y0, t_span, t_eval)
    if y.shape[0] != 1:
        raise ParameterError(f"rk45_reference integrates one system, got {y.shape[0]}")

    def fun(t: float, x: FloatArray) -> FloatArray:
        out: FloatArray = rhs(np.array([t]), x[None])[0]
        return out

    event_time = np.full(1, np.nan)
    events = []
    if event is not None:
        ev = event

        def g(t: float, x: FloatArray) -> float:
            return float(ev(np.array([t]), x[None])[0])

        g.direction = -1  # type: ignore[attr-defined]
        events.append(g)
        if g(t_span[0], y[0]) < 0:
            event_time[0] = t_span[0]
    try:
        sol = solve_ivp(fun, t_span, y[0], method="RK45", t_eval=te, rtol=rtol, atol=atol, events=events or None)
    except ValueError as exc:
        raise SolverError(f"solve_ivp failed: {exc}") from exc
    if not sol.success:
        raise SolverError(f"solve_ivp failed: {sol.message}")
    if event is not None and np.isnan(event_time[0]) and sol.t_events[0].size:
        event_time[0] = float(sol.t_events[0][0])
    n_steps = np.array([max(sol.nfev - 2, 0) // 6])  # 6 evaluations per step (FSAL) + 2 for the first step
    return BatchSolution(
        t=te, y=sol.y.T[:, None, :], event_time=event_time, n_steps=n_steps, n_rejected=np.zeros(1, dtype=int)
    )


__all__ = ["rk45_reference"]
