"""Paper scenarios (Section V) built from a configuration and its certificate."""

from __future__ import annotations

import numpy as np

from .certificate import certify
from .config import FormationConfig, preset_config
from .control_law import FormationController, SineTrajectory, heading_gains
from .exceptions import DesignError
from .formation import offsets_from_shape
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
    off = offsets_from_shape(np.asarray(cfg.shape), cfg.transform)
    c, s = np.cos(0.3), np.sin(0.3)
    pos = 1.5 * off @ np.array([[c, s], [-s, c]])
    init = np.zeros((cfg.n, 6))
    init[:, 0:2] = pos
    init[:, 3] = 1.0
    return init


def scenario_from_config(
    cfg: FormationConfig,
    *,
    horizon: float = 300.0,
    plant: VehicleParams | None = None,
    current: tuple[float, float] = (0.0, 0.0),
    orientation: str = "corrected",
    thrust_limit: tuple[float, float, float] | None = None,
    initial: np.ndarray | None = None,
) -> Scenario:
    """Certify ``cfg`` and build the closed-loop scenario with the certified gain.

    Raises
    ------
    DesignError
        If the configured method gives no gain (e.g. gamma below the Theorem 1 bound).
    """
    cert = certify(cfg, jacobi_samples=200)
    if cert.alpha_used is None:
        raise DesignError(f"no gain for method {cfg.method!r}: {'; '.join(cert.reasons)}")
    ctrl = FormationController(
        params=cfg.vehicle, transform=cfg.transform, shape=np.asarray(cfg.shape),
        trajectory=SineTrajectory(), alpha=cert.alpha_used, k1=cfg.k1,
        k_psi=heading_gains(cfg.vehicle), orientation=orientation,  # type: ignore[arg-type]
        thrust_limit=thrust_limit,
    )
    if initial is None:
        initial = PAPER_TRIANGLE_INITIAL if cfg.name == "paper-triangle" else default_initial(cfg)
    return Scenario(
        controller=ctrl, plant=plant or cfg.vehicle, initial=initial, horizon=horizon,
        current=current, envelope=cfg.envelope, name=cfg.name,
    )


def paper_scenario(name: str = "paper-triangle", **kwargs: object) -> Scenario:
    """Scenario of a built-in preset (``paper-triangle`` or ``paper-hexagon``)."""
    return scenario_from_config(preset_config(name), **kwargs)  # type: ignore[arg-type]


__all__ = ["PAPER_TRIANGLE_INITIAL", "default_initial", "paper_scenario", "scenario_from_config"]
