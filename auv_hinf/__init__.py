"""auv-hinf: certified H-infinity formation control for fleets of AUVs.

Implements and extends Yang & Zhang, *Robust Control of Horizontal Formation Dynamics
for Autonomous Underwater Vehicles*. See the README for a tour.

The public names below are imported when first used (PEP 562): ``import auv_hinf`` and the
command line's ``--help``, ``init`` and configuration errors do not pay for python-control,
SciPy's signal tools and Matplotlib (about 2.5 s), which only the certificates and simulations need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from auv_hinf._version import __version__

if TYPE_CHECKING:
    from auv_hinf.certificate.assembly import Certificate, certify
    from auv_hinf.certificate.design_point import DesignPoint, design_point
    from auv_hinf.certificate.run_plan import RunPlan, guidance_run, plan_run, run_report
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

#: Where each public name lives: ``auv_hinf.<name>`` imports that module on first use.
_LAZY: dict[str, tuple[str, ...]] = {
    "auv_hinf.certificate.assembly": ("Certificate", "certify"),
    "auv_hinf.certificate.design_point": ("DesignPoint", "design_point"),
    "auv_hinf.certificate.run_plan": ("RunPlan", "guidance_run", "plan_run", "run_report"),
    "auv_hinf.closed_loop.coverage": ("Coverage", "cover_start"),
    "auv_hinf.closed_loop.nominal": ("ClosedLoopCertificate", "closed_loop_certificate"),
    "auv_hinf.closed_loop.region": ("Region",),
    "auv_hinf.config.presets": ("PRESETS", "preset_config"),
    "auv_hinf.config.settings": ("FormationConfig", "load_config"),
    "auv_hinf.design.blocks": ("hinf_norm", "hinf_norm_peak", "position_block", "velocity_block"),
    "auv_hinf.design.brl": ("lmi_hinf_norm",),
    "auv_hinf.design.crosscheck": ("CrosscheckReport", "crosscheck"),
    "auv_hinf.design.jacobi_sigma": ("jacobi_sigma_bounds",),
    "auv_hinf.design.sigma": ("SigmaBounds", "sigma_grid", "sigma_max_2x2", "vehicle_sigma"),
    "auv_hinf.design.theorem1": (
        "GainDesign",
        "Theorem1Conditions",
        "alpha_minimal",
        "alpha_paper",
        "alpha_stabilizing",
        "design_alpha",
        "position_loop",
        "theorem1_conditions",
        "theorem1_gains",
    ),
    "auv_hinf.exceptions": (
        "AuvHinfError",
        "ConfigError",
        "DesignError",
        "EnvelopeError",
        "FormationError",
        "ParameterError",
        "SolverError",
    ),
    "auv_hinf.law.formation_law": ("FormationController", "VehicleLaw"),
    "auv_hinf.law.gains": ("Gains", "heading_gains"),
    "auv_hinf.mission.fit": ("ReferenceFit", "reference_fit"),
    "auv_hinf.mission.fleet": ("FleetReference", "PathFrameReference", "shaped_start"),
    "auv_hinf.mission.margins": ("ErrorBounds",),
    "auv_hinf.mission.paths": ("CircleReference", "LawnmowerReference", "LineReference", "SineReference"),
    "auv_hinf.models.envelope": ("Envelope", "envelope_lambda"),
    "auv_hinf.models.jacobi": (
        "FormationMatrices",
        "JacobiTransform",
        "formation_matrices",
        "offsets_from_shape",
        "regular_polygon",
        "shape_from_offsets",
    ),
    "auv_hinf.models.vehicle": (
        "VehicleParams",
        "body_block",
        "inertial_block",
        "input_matrix",
        "paper2011",
        "remus100",
        "rhs",
        "vehicle_nlsys",
    ),
    "auv_hinf.simulation.engine": ("simulate", "simulate_batch"),
    "auv_hinf.simulation.results": ("SimulationResult",),
    "auv_hinf.simulation.scenario": ("Scenario", "ScenarioBatch"),
}
_HOME = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str) -> Any:
    """Import the public name ``name`` from its module on first use, and keep it."""
    module = _HOME.get(name)
    if module is None:
        raise AttributeError(f"module 'auv_hinf' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names, imported or not."""
    return sorted(set(globals()) | set(_HOME))


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
    "guidance_run",
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
