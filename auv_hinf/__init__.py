"""auv-hinf: certified H-infinity formation control for fleets of AUVs.

Implements and extends Yang & Zhang, *Robust Control of Horizontal Formation Dynamics
for Autonomous Underwater Vehicles*. See the README for a tour.
"""

from auv_hinf._version import __version__
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.design_point import DesignPoint, design_point
from auv_hinf.certificate.run_plan import RunPlan, plan_run, run_report
from auv_hinf.closed_loop.coverage import Coverage, cover_start
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate, closed_loop_certificate
from auv_hinf.closed_loop.region import Region
from auv_hinf.config.presets import PRESETS, preset_config
from auv_hinf.config.settings import FormationConfig, load_config
from auv_hinf.design.blocks import hinf_norm, hinf_norm_peak, position_block, velocity_block
from auv_hinf.design.brl import lmi_hinf_norm
from auv_hinf.design.crosscheck import CrosscheckReport, crosscheck
from auv_hinf.design.jacobi_sigma import jacobi_sigma_bounds
from auv_hinf.design.sigma import SigmaBounds, sigma_grid, sigma_max_2x2, vehicle_sigma
from auv_hinf.design.theorem1 import (
    GainDesign,
    Theorem1Conditions,
    alpha_minimal,
    alpha_paper,
    alpha_stabilizing,
    design_alpha,
    position_loop,
    theorem1_conditions,
    theorem1_gains,
)
from auv_hinf.exceptions import (
    AuvHinfError,
    ConfigError,
    DesignError,
    EnvelopeError,
    FormationError,
    ParameterError,
    SolverError,
)
from auv_hinf.law.formation_law import FormationController, VehicleLaw
from auv_hinf.law.gains import Gains, heading_gains
from auv_hinf.mission.fit import ReferenceFit, reference_fit
from auv_hinf.mission.fleet import FleetReference, PathFrameReference, shaped_start
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.mission.paths import CircleReference, LawnmowerReference, LineReference, SineReference
from auv_hinf.models.envelope import Envelope, envelope_lambda
from auv_hinf.models.jacobi import (
    FormationMatrices,
    JacobiTransform,
    formation_matrices,
    offsets_from_shape,
    regular_polygon,
    shape_from_offsets,
)
from auv_hinf.models.vehicle import (
    VehicleParams,
    body_block,
    inertial_block,
    input_matrix,
    paper2011,
    remus100,
    rhs,
    vehicle_nlsys,
)
from auv_hinf.simulation.engine import simulate, simulate_batch
from auv_hinf.simulation.results import SimulationResult
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch

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
    "DesignPoint",
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
    "PathFrameReference",
    "ReferenceFit",
    "Region",
    "RunPlan",
    "Scenario",
    "ScenarioBatch",
    "SigmaBounds",
    "SimulationResult",
    "SineReference",
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
    "design_point",
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
    "reference_fit",
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
    "theorem1_gains",
    "vehicle_nlsys",
    "vehicle_sigma",
    "velocity_block",
]
