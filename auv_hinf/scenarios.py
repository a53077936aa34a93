"""Paper scenarios (Section V) built from a configuration and its Theorem 1 gain."""

from __future__ import annotations

import numpy as np

from ._typing import OrientationLaw
from .config import FormationConfig, preset_config
from .control_law import MotionSource, VehicleLaw, heading_gains
from .design import design_alpha
from .envelope import envelope_lambda
from .exceptions import DesignError
from .paths import SineReference
from .postprocess import positions_from_jacobi
from .reference import FleetReference
from .sigma import vehicle_sigma
from .simulation import Scenario
from .vehicle import VehicleParams

#: Section V: positions (m), u = v = 1 m/s, psi = 0.1, 0.4, 0.7 rad, r1 = r2 = 0.1 rad/s
#: (r3 is not given in the paper: 0).
PAPER_TRIANGLE_INITIAL = np.array(
    [[25.0, 5.0, 0.1, 1.0, 1.0, 0.1], [-5.0, 10.0, 0.4, 1.0, 1.0, 0.1], [10.0, 8.0, 0.7, 1.0, 1.0, 0.0]]
)


def default_initial(cfg: FormationConfig) -> np.ndarray:
    """Initial states for configurations without given ones (Fig. 3 gives none).

    Vehicles start on the desired shape scaled by 1.5 and rotated by 0.3 rad about the
    origin, heading 0, surge 1 m/s, at rest otherwise.
    """
    off = config_offsets(cfg)
    c, s = np.cos(0.3), np.sin(0.3)
    pos = 1.5 * off @ np.array([[c, s], [-s, c]])
    init = np.zeros((cfg.n, 6))
    init[:, 0:2] = pos
    init[:, 3] = 1.0
    return init


def config_offsets(cfg: FormationConfig) -> np.ndarray:
    """Vehicle offsets from the formation centre, shape ``(N, 2)`` (m), computed in O(N)."""
    rho = np.asarray(cfg.shape, dtype=float).reshape(cfg.n - 1, 2)
    return positions_from_jacobi(np.vstack([rho, np.zeros((1, 2))]), cfg.jacobi)


def config_alpha(cfg: FormationConfig) -> float:
    """Theorem 1 velocity gain (1/s) of ``cfg`` on its envelope, without a full certificate.

    ``lam`` = ``cfg.lam`` or :func:`~auv_hinf.envelope.envelope_lambda`; ``sigma`` = the exact
    vehicle-coordinate bound (upper); ``gamma`` = ``cfg.gamma`` or ``1/sigma``.

    Raises
    ------
    DesignError
        If the configured method gives no gain (e.g. gamma below the Theorem 1 bound).
    """
    lam = cfg.lam if cfg.lam is not None else envelope_lambda(cfg.vehicle, cfg.envelope)
    sigma = vehicle_sigma(cfg.vehicle, cfg.envelope, lam, cfg.n).upper
    gamma = cfg.gamma if cfg.gamma is not None else 1.0 / sigma
    alpha = design_alpha(lam, gamma, cfg.method).alpha
    if not np.isfinite(alpha):
        raise DesignError(f"no finite gain for method {cfg.method!r} at lambda={lam:g}, gamma={gamma:g}")
    return float(alpha)


def scenario_from_config(
    cfg: FormationConfig,
    *,
    horizon: float = 300.0,
    plant: VehicleParams | None = None,
    current: tuple[float, float] = (0.0, 0.0),
    orientation: OrientationLaw = "corrected",
    thrust_limit: tuple[float, float, float] | None = None,
    initial: np.ndarray | None = None,
    samples: int = 3001,
    reference: MotionSource | None = None,
) -> Scenario:
    """Closed-loop scenario of ``cfg``: the paper's sine centre path, offsets from ``cfg.shape``.

    The law uses the Theorem 1 gain of :func:`config_alpha` and heading gains by pole
    placement; ``initial`` defaults to the paper's states for ``paper-triangle`` and to
    :func:`default_initial` otherwise. ``reference`` (e.g. a shaped
    :class:`~auv_hinf.reference.FleetReference`) replaces the plain sine mission.
    """
    law = VehicleLaw(
        params=cfg.vehicle,
        alpha=config_alpha(cfg),
        k1=cfg.k1,
        k_psi=heading_gains(cfg.vehicle),
        orientation=orientation,
        thrust_limit=thrust_limit,
    )
    if initial is None:
        initial = PAPER_TRIANGLE_INITIAL if cfg.name == "paper-triangle" else default_initial(cfg)
    return Scenario(
        law=law,
        reference=reference or FleetReference(SineReference(), config_offsets(cfg)),
        plant=plant or cfg.vehicle,
        initial=initial,
        horizon=horizon,
        current=current,
        envelope=cfg.envelope,
        samples=samples,
        name=cfg.name,
        jacobi=cfg.jacobi,
    )


def paper_scenario(name: str = "paper-triangle", **kwargs: object) -> Scenario:
    """Scenario of a built-in preset (``paper-triangle`` or ``paper-hexagon``)."""
    return scenario_from_config(preset_config(name), **kwargs)  # type: ignore[arg-type]


__all__ = [
    "PAPER_TRIANGLE_INITIAL",
    "config_alpha",
    "config_offsets",
    "default_initial",
    "paper_scenario",
    "scenario_from_config",
]
