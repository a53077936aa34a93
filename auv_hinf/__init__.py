"""auv-hinf: certified H-infinity formation control for fleets of AUVs.

Implements and extends Yang & Zhang, *Robust Control of Horizontal Formation Dynamics
for Autonomous Underwater Vehicles*. See the README for a tour.
"""

from .certificate import Certificate, certify
from .closed_loop import ClosedLoopCertificate, closed_loop_certificate
from .config import FormationConfig, load_config, preset_config
from .control_law import FormationController, SineTrajectory, VehicleLaw, heading_gains
from .coverage import Coverage, cover_start
from .crosscheck import CrosscheckReport, crosscheck
from .design import (
    GainDesign,
    Theorem1Conditions,
    alpha_minimal,
    alpha_paper,
    alpha_stabilizing,
    design_alpha,
    position_loop,
    theorem1_conditions,
)
from .envelope import Envelope, envelope_lambda
from .exceptions import (
    AuvHinfError,
    ConfigError,
    DesignError,
    EnvelopeError,
    FormationError,
    ParameterError,
    SolverError,
)
from .formation import (
    FormationMatrices,
    JacobiTransform,
    formation_matrices,
    offsets_from_shape,
    regular_polygon,
    shape_from_offsets,
)
from .jacobi_sigma import jacobi_sigma_bounds
from .lmi import lmi_hinf_norm
from .loops import hinf_norm, hinf_norm_peak, position_block, velocity_block
from .plan import Gains, RunPlan, design_gains, plan_run, run_report
from .presets import PRESETS
from .reference import (
    CircleReference,
    FleetReference,
    LawnmowerReference,
    LineReference,
    SineReference,
    shaped_start,
)
from .region import ErrorBounds, Region
from .sigma import SigmaBounds, sigma_grid, sigma_max_2x2, vehicle_sigma
from .simulation import Scenario, ScenarioBatch, SimulationResult, simulate, simulate_batch
from .vehicle import (
    VehicleParams,
    body_block,
    inertial_block,
    input_matrix,
    paper2011,
    remus100,
    rhs,
    vehicle_nlsys,
)

__version__ = "0.2.0"

__all__ = [
    "PRESETS",
    "AuvHinfError",
    "Certificate",
    "CircleReference",
    "ClosedLoopCertificate",
    "ConfigError",
    "Coverage",
    "CrosscheckReport",
    "DesignError",
    "Envelope",
    "EnvelopeError",
    "ErrorBounds",
    "FleetReference",
    "FormationConfig",
    "FormationController",
    "FormationError",
    "FormationMatrices",
    "GainDesign",
    "Gains",
    "JacobiTransform",
    "LawnmowerReference",
    "LineReference",
    "ParameterError",
    "Region",
    "RunPlan",
    "Scenario",
    "ScenarioBatch",
    "SigmaBounds",
    "SimulationResult",
    "SineReference",
    "SineTrajectory",
    "SolverError",
    "Theorem1Conditions",
    "VehicleLaw",
    "VehicleParams",
    "__version__",
    "alpha_minimal",
    "alpha_paper",
    "alpha_stabilizing",
    "body_block",
    "certify",
    "closed_loop_certificate",
    "cover_start",
    "crosscheck",
    "design_alpha",
    "design_gains",
    "envelope_lambda",
    "formation_matrices",
    "heading_gains",
    "hinf_norm",
    "hinf_norm_peak",
    "inertial_block",
    "input_matrix",
    "jacobi_sigma_bounds",
    "lmi_hinf_norm",
    "load_config",
    "offsets_from_shape",
    "paper2011",
    "plan_run",
    "position_block",
    "position_loop",
    "preset_config",
    "regular_polygon",
    "remus100",
    "rhs",
    "run_report",
    "shape_from_offsets",
    "shaped_start",
    "sigma_grid",
    "sigma_max_2x2",
    "simulate",
    "simulate_batch",
    "theorem1_conditions",
    "vehicle_nlsys",
    "vehicle_sigma",
    "velocity_block",
]
