"""The readable table of a certificate (``auv-hinf certify`` without ``--json``)."""

from __future__ import annotations

from typing import Any, Protocol


class CertificateView(Protocol):
    """What the table reads from a :class:`~auv_hinf.certificate.assembly.Certificate`."""

    @property
    def config(self) -> Any: ...

    @property
    def lam(self) -> float: ...

    @property
    def sigma(self) -> Any: ...

    @property
    def sigma_jacobi(self) -> Any: ...

    @property
    def gamma(self) -> float: ...

    @property
    def theorem1(self) -> Any: ...

    @property
    def designs(self) -> dict[str, Any]: ...

    @property
    def small_gain_margin(self) -> float | None: ...

    @property
    def position_loop_hinf(self) -> float | None: ...

    @property
    def crosscheck(self) -> Any: ...

    @property
    def certified(self) -> bool: ...

    @property
    def reasons(self) -> tuple[str, ...]: ...

    @property
    def closed_loop(self) -> Any: ...

    @property
    def robust(self) -> Any: ...

    @property
    def gains(self) -> Any: ...

    @property
    def gain_source(self) -> str: ...

    @property
    def actuators(self) -> Any: ...

    @property
    def implementation(self) -> Any: ...


def certificate_text(cert: CertificateView) -> str:
    """One line per quantity, with units; the verdict and its reasons last."""

    def fmt(x: float | None) -> str:
        return "n/a" if x is None else f"{x:.6g}"

    lines = [
        f"auv-hinf certificate: {cert.config.name} (N={cert.config.n}, {cert.config.vehicle.name})",
        f"  lambda (envelope)         {fmt(cert.lam)} 1/s",
        f"  sigma vehicle  [lo, up]   [{fmt(cert.sigma.lower)}, {fmt(cert.sigma.upper)}]  <- used",
        f"  sigma Jacobi   [lo, up]   [{fmt(cert.sigma_jacobi.lower)}, {fmt(cert.sigma_jacobi.upper)}]",
        f"  {'gamma = 1/sigma' if cert.config.gamma is None else 'gamma (configured)':<26}"
        f"{fmt(cert.gamma)} s  (Theorem 1 minimum {fmt(cert.theorem1.gamma_min)} s)",
    ]
    for m, d in cert.designs.items():
        mark = " <- used" if m == cert.config.method and cert.gain_source == "theorem1" else ""
        lines.append(f"  alpha[{m:<11}]        {fmt(None if d is None else d.alpha)}{mark}")
        if d is not None:
            lines.extend(f"      ! {f}" for f in d.flags)
    lines += [
        f"  small-gain margin         {fmt(cert.small_gain_margin)} 1/s",
        f"  position loop ||T||       {fmt(cert.position_loop_hinf)} (Theorem 2, k1={cert.config.k1:g})",
        f"  cross-check               {'ok' if cert.crosscheck.ok else 'DISAGREES'} "
        f"(max rel {cert.crosscheck.max_rel_diff:.2g})",
    ]
    lines.append(
        f"  gains that run            {'none' if cert.gains is None else cert.gains.describe()}"
        f"{'  (robust design)' if cert.gain_source == 'robust' else ''}"
    )
    if cert.closed_loop is not None:
        lines += cert.closed_loop.lines()
    elif cert.gains is not None and cert.gains.integral:
        lines += ["  closed loop (paper's law) not applicable: integral action is certified by the robust certificate"]
    else:
        lines += ["  closed loop               not certified"]
    lines += [] if cert.robust is None else cert.robust.lines()
    lines += [] if cert.actuators is None else cert.actuators.lines()
    lines += [] if cert.implementation is None else cert.implementation.lines()
    lines += [f"  CERTIFIED: {'yes' if cert.certified else 'no'}"]
    lines.extend(f"    - {r}" for r in cert.reasons)
    return "\n".join(lines)


__all__ = ["CertificateView", "certificate_text"]
