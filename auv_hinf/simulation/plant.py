"""The simulated vehicles: body forces to state derivative, in the water current.

Shared by the continuous closed loop (:func:`~auv_hinf.simulation.engine.fleet_derivative`,
the law evaluated at every stage) and the sampled one (:mod:`auv_hinf.simulation.sampled`,
forces held between samples).
"""

from __future__ import annotations

from auv_hinf._typing import FloatArray
from auv_hinf.models.vehicle import VehicleParams, rhs
from auv_hinf.simulation.postprocess import ground_velocity


def plant_derivative(
    plant: VehicleParams,
    current: FloatArray,
    states: FloatArray,
    forces: FloatArray,
    cs: tuple[FloatArray, FloatArray],
    p_dot: FloatArray | None = None,
) -> FloatArray:
    """``d/dt`` of states ``(..., N, 6)`` under body forces ``(..., N, 3)`` (N, N, N m).

    The position rate is the ground velocity ``R(psi) [u, v] + current`` (``current``
    broadcasts to ``(..., N, 2)``, inertial, m/s); ``cs`` is ``(cos psi, sin psi)``, and
    ``p_dot`` that ground velocity when the caller has it.
    """
    ground = ground_velocity(states, current, cs) if p_dot is None else p_dot
    d = rhs(plant, states, forces, cs)
    d[..., 0:2] = ground
    return d


__all__ = ["plant_derivative"]
