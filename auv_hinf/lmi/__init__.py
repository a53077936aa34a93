"""Linear matrix inequalities in cvxpy, solved by Clarabel: the only package that imports cvxpy.

* the Riccati *inequality* whose extremal solution is the stabilising root of eq. (37)
  (:func:`lmi_stabilizing_alpha`);
* bounded-real-lemma analysis, the H-infinity norm of any ``StateSpace``
  (:func:`lmi_hinf_norm`);
* BRL synthesis of the minimal alpha for a given gamma, by bisection on alpha over full-size
  BRL analyses (:func:`lmi_minimal_alpha`);
* closed-loop Lyapunov LMIs of the position and heading error loops, for decay rates
  (:func:`lmi_position_lyapunov`, :func:`lmi_heading_lyapunov`) and for invariant
  regions (:func:`lmi_position_region`, :func:`lmi_heading_region`).

Every solve must return status ``optimal``; the answer is re-verified with numpy eigenvalues of
the LMI matrix, because cvxpy symmetrises PSD constraints silently.
"""

from .core import BISECTION_RTOL, LMI_MARGIN, LMI_RTOL, LMI_VERIFY_TOL, LmiResult, solve, verify_nsd
from .gains import MODAL_COND_MAX, lmi_hinf_norm, lmi_minimal_alpha, lmi_stabilizing_alpha
from .lyapunov import (
    EIG_ROUNDOFF_FACTOR,
    LYAP_STRICT_RTOL,
    LyapunovResult,
    heading_lmi_matrices,
    lmi_heading_lyapunov,
    lmi_heading_region,
    lmi_position_lyapunov,
    lmi_position_region,
    position_lmi_matrix,
    roundoff_margin,
    strict_nsd_gap,
)

__all__ = [
    "BISECTION_RTOL",
    "EIG_ROUNDOFF_FACTOR",
    "LMI_MARGIN",
    "LMI_RTOL",
    "LMI_VERIFY_TOL",
    "LYAP_STRICT_RTOL",
    "MODAL_COND_MAX",
    "LmiResult",
    "LyapunovResult",
    "heading_lmi_matrices",
    "lmi_heading_lyapunov",
    "lmi_heading_region",
    "lmi_hinf_norm",
    "lmi_minimal_alpha",
    "lmi_position_lyapunov",
    "lmi_position_region",
    "lmi_stabilizing_alpha",
    "position_lmi_matrix",
    "roundoff_margin",
    "solve",
    "strict_nsd_gap",
    "verify_nsd",
]
