"""An independent, slow reference of the sampled loop: scipy DOP853 per hold, the law in numpy.

It shares nothing with :mod:`auv_hinf.implementation.sampled_loop` but the convention: at ``t_k`` the law
is evaluated on the state at ``s_k`` (from the dense output of the holds already integrated)
plus the given noise, against the reference at ``s_k``, and held to ``t_{k+1}``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from auv_hinf.law.formation_law import saturate
from auv_hinf.models.vehicle import ground_velocity, plant_derivative
from auv_hinf.simulation.scenario import Scenario

#: Tolerance of the reference (rtol = atol), far below the product's 1e-8.
TIGHT = 1e-12


def reference_loop(scn: Scenario, times, measured_at, noise, t_out):
    """States ``(T, N, 6)`` at ``t_out`` and forces ``(K, N, 3)`` of the sampled loop of ``scn``.

    ``times (K,)`` are the sample instants, ``measured_at (K,)`` the measurement instants and
    ``noise (K, N, 6)`` the measurement errors (all given, e.g. from a trace).
    """
    n, cur = scn.n, np.asarray(scn.current)
    grid = np.append(times, scn.horizon)
    y = scn.initial.copy()
    pieces = []

    def state_at(s):
        if s <= 0.0:
            return scn.initial.copy()
        for lo, hi, sol in pieces:
            if lo <= s <= hi:
                return sol(s).reshape(n, 6)
        raise AssertionError(f"no integrated hold covers t = {s}")

    forces = []
    for k in range(times.size):
        meas = state_at(measured_at[k]) + noise[k]
        tau = scn.law.unsaturated(meas, ground_velocity(meas, cur), scn.reference.motion(measured_at[k]))
        held = saturate(tau, scn.law.actuators)[0]
        forces.append(held)

        def f(t, x, held=held):
            s = x.reshape(n, 6)
            return plant_derivative(scn.plant, cur, s, held, (np.cos(s[:, 2]), np.sin(s[:, 2]))).ravel()

        r = solve_ivp(f, (grid[k], grid[k + 1]), y.ravel(), method="DOP853", rtol=TIGHT, atol=TIGHT, dense_output=True)
        pieces.append((grid[k], grid[k + 1], r.sol))
        y = r.y[:, -1].reshape(n, 6)
    out = np.array([state_at(t) if t > 0 else scn.initial for t in t_out])
    return out, np.array(forces)
