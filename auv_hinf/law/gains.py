"""The gains of the formation law: one type, and the Theorem 1 derivation of it.

:class:`Gains` is the only way gains travel through the package: the design, the
certificates, the law, the simulator, campaigns, the printed and saved reports and the
python-control export all take the same object, so the gains that run are the gains that
are printed, saved and exported.

:func:`theorem1_gains` derives them from the configuration's design table: the velocity gain
``alpha`` of Theorem 1 (one of the three methods of :mod:`auv_hinf.design.theorem1`), the
position gain ``k1`` as configured, and the heading gains by pole placement
(:func:`heading_gains`). The robust design (:mod:`auv_hinf.robust.bandwidth`) produces the
same type.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from auv_hinf.exceptions import DesignError, require_finite
from auv_hinf.models.vehicle import VehicleParams

#: Where a design's gains come from: Theorem 1, the robust (box) design, or the deployed
#: (composed) design. The certificate file's ``gains.source`` takes the same names.
GainSource = Literal["theorem1", "robust", "deployed"]

#: The Theorem 2 position gain of the paper's examples (1/s^2): the default of ``[design] k1``.
DEFAULT_K1 = 0.5


@dataclass(frozen=True)
class Gains:
    """Gains of the per-vehicle formation law.

    Attributes
    ----------
    alpha : float
        Velocity gain (1/s): ``mu = -alpha Ze``.
    k1 : float
        Position gain ``K1 = k1 I`` (1/s^2), > 0.
    k_psi : tuple of float
        Heading gains ``(k1_psi, k2_psi)`` (1/s^2, 1/s).
    ki : float
        Integral gain of the position loop (1/s^3): ``w_i = ... - ki z_i`` with
        ``z_i' = p_i - p_id``. Zero (the default, the paper's law) means no integral action.

    Raises
    ------
    DesignError
        If a gain is not finite, ``k1 <= 0`` or ``ki < 0``.
    """

    alpha: float
    k1: float
    k_psi: tuple[float, float]
    ki: float = 0.0

    def __post_init__(self) -> None:
        alpha = float(require_finite("alpha", self.alpha))
        k1 = float(require_finite("k1", self.k1))
        if k1 <= 0.0:
            raise DesignError(f"k1 must be > 0 (K1 positive definite), got {k1!r}")
        k_psi = tuple(float(require_finite("k_psi", x)) for x in self.k_psi)
        if len(k_psi) != 2:
            raise DesignError(f"k_psi must be two numbers (k1_psi, k2_psi), got {self.k_psi!r}")
        ki = float(require_finite("ki", self.ki))
        if ki < 0.0:
            raise DesignError(f"the integral gain ki must be >= 0, got {ki!r}")
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "k1", k1)
        object.__setattr__(self, "k_psi", k_psi)
        object.__setattr__(self, "ki", ki)

    @property
    def integral(self) -> bool:
        """Whether the position loop has integral action (``ki > 0``)."""
        return self.ki > 0.0

    def to_dict(self) -> dict[str, Any]:
        """``{"alpha": 1/s, "k1": 1/s^2, "k_psi": [1/s^2, 1/s]}``, and ``"ki"`` (1/s^3) when integral."""
        out: dict[str, Any] = {"alpha": self.alpha, "k1": self.k1, "k_psi": list(self.k_psi)}
        if self.integral:
            out["ki"] = self.ki
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Gains:
        """Inverse of :meth:`to_dict` (other keys, such as a report's ``source``, are ignored).

        Parameters
        ----------
        data : mapping
            ``alpha`` (1/s), ``k1`` (1/s^2), ``k_psi`` (1/s^2, 1/s) and optionally ``ki`` (1/s^3).
        """
        k_psi = data["k_psi"]
        return cls(
            float(data["alpha"]), float(data["k1"]), (float(k_psi[0]), float(k_psi[1])), float(data.get("ki", 0.0))
        )

    def describe(self) -> str:
        """One line with units, as the reports print it."""
        line = (
            f"alpha {self.alpha:.6g} 1/s, k1 {self.k1:.6g} 1/s^2, "
            f"k_psi ({self.k_psi[0]:.6g} 1/s^2, {self.k_psi[1]:.6g} 1/s)"
        )
        return line + (f", ki {self.ki:.6g} 1/s^3" if self.integral else "")


#: Rate of the integrator's closed-loop pole as a share of the slower pole of the position
#: loop without it (1). A third keeps the integrator slower than the loop it corrects, so the
#: two remaining poles stay close to the proportional design's (the phase it costs is small),
#: while the offset a constant current leaves still decays within a few slow time constants.
INTEGRAL_POLE_SHARE = 1.0 / 3.0


def integral_gain(alpha: float, k1: float, lam: float, input_gain: float) -> float:
    """The integral gain ``ki`` (1/s^3) that adds a real pole at ``-rho`` to the centre position loop.

    The centre loop ``s^2 + b s + k``, ``b = l alpha - lam``, ``k = l k1`` (``l`` the input gain
    ``m_hat/m``, 1 for an exact model) with integral action becomes
    ``s^3 + b s^2 + k s + l ki``. Choosing ``l ki = rho (k - rho (b - rho))`` factors it as
    ``(s + rho) (s^2 + (b - rho) s + k - rho (b - rho))``, with ``rho`` =
    :data:`INTEGRAL_POLE_SHARE` times the slower root's rate of ``s^2 + b s + k``: all three
    poles stay in the open left half plane.

    Parameters
    ----------
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    lam : float
        Envelope lambda of the plant (1/s).
    input_gain : float
        ``l = m_hat/m``, the controller's mass over the plant's (dimensionless; 1 for an exact model).

    Raises
    ------
    DesignError
        If the loop without integral action is not stable (``b <= 0`` or ``k <= 0``).
    """
    b, k = input_gain * alpha - lam, input_gain * k1
    if not (b > 0.0 and k > 0.0):
        raise DesignError(f"integral action needs a stable position loop, got l alpha - lam = {b:g}, l k1 = {k:g}")
    slow = float(np.roots([1.0, b, k]).real.max())  # the slower root (closest to zero), < 0
    rho = -INTEGRAL_POLE_SHARE * slow
    return rho * (k - rho * (b - rho)) / input_gain


def with_integral(gains: Gains, lam: float, input_gain: float) -> Gains:
    """``gains`` with the integral gain of :func:`integral_gain` for their ``alpha`` and ``k1``.

    Parameters
    ----------
    gains : Gains
        The proportional gains; any ``ki`` is replaced.
    lam : float
        Envelope lambda of the plant (1/s).
    input_gain : float
        ``l = m_hat/m`` (dimensionless), as in :func:`integral_gain`.
    """
    return replace(gains, ki=integral_gain(gains.alpha, gains.k1, lam, input_gain))


def heading_gains(params: VehicleParams, poles: tuple[float, float]) -> tuple[float, float]:
    """``(k1_psi, k2_psi)`` by pole placement (``control.place``) on eq. (27) at ``r = 0``.

    The heading-error model is ``e'' = -(d33_lin/m33) e' + V``.

    Parameters
    ----------
    params : VehicleParams
        The controller's model of the vehicle.
    poles : tuple of float
        The two closed-loop heading poles (1/s), finite and negative.

    Raises
    ------
    DesignError
        If a pole is not finite and negative.
    """
    if len(poles) != 2 or any((not np.isfinite(p)) or p >= 0 for p in poles):
        raise DesignError(f"heading poles must be two finite negative numbers, got {poles!r}")
    a = np.array([[0.0, 1.0], [0.0, -params.d33_lin / params.m33]])
    b = np.array([[0.0], [1.0]])
    import control as ct  # imported here: the configuration layer imports this module, python-control costs ~1 s

    k = np.asarray(ct.place(a, b, list(poles))).ravel()
    return float(k[0]), float(k[1])


__all__ = [
    "DEFAULT_K1",
    "INTEGRAL_POLE_SHARE",
    "GainSource",
    "Gains",
    "heading_gains",
    "integral_gain",
    "with_integral",
]
