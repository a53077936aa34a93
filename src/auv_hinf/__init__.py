"""auv-hinf: certified H-infinity formation control for fleets of AUVs.

Implements and extends Yang & Zhang, *Robust Control of Horizontal Formation Dynamics
for Autonomous Underwater Vehicles*. See the README for a tour.
"""

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

__version__ = "0.1.0"

__all__ = [
    "AuvHinfError",
    "ConfigError",
    "DesignError",
    "EnvelopeError",
    "FormationError",
    "FormationMatrices",
    "JacobiTransform",
    "ParameterError",
    "SolverError",
    "VehicleParams",
    "__version__",
    "body_block",
    "formation_matrices",
    "inertial_block",
    "input_matrix",
    "offsets_from_shape",
    "paper2011",
    "regular_polygon",
    "remus100",
    "rhs",
    "shape_from_offsets",
    "vehicle_nlsys",
]
