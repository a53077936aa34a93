"""Table 6: robust design of the BlueROV2 fleet (N = 4) with its thruster limits: LMI synthesis
against the bandwidth family, both certified by the same robust certificate."""

from __future__ import annotations

import time
from dataclasses import replace

from common import REPEATS, table

from auv_hinf.actuation.limits import Actuators
from auv_hinf.certificate.design_point import design_point
from auv_hinf.config.presets import preset_config
from auv_hinf.law.gains import Gains
from auv_hinf.robust.bandwidth import design_robust
from auv_hinf.robust.invariant_set import clear_ellipsoid_caches
from auv_hinf.robust.synthesis import synthesise_robust


def _timed_design(fn: object, *args: object) -> tuple[float, object]:
    """Median wall time (s) of ``fn(*args)`` over REPEATS cold calls (ellipsoid caches emptied), and the result."""
    times, out = [], None
    for _ in range(REPEATS):
        clear_ellipsoid_caches()
        t = time.perf_counter()
        out = fn(*args)  # type: ignore[operator]
        times.append(time.perf_counter() - t)
    return sorted(times)[len(times) // 2], out


def synthesis() -> str:
    rows = []
    for name in ("bluerov2-line", "remus-line"):
        cfg = preset_config(name)
        point = design_point(replace(cfg, robust=False))  # the tube, box and current only
        # a propeller-and-rudder vehicle (the REMUS) has no limits of the fully actuated law's forces:
        # its design is timed without limits (certify refuses that law on it, docs/vehicles.md)
        act: Actuators | None = cfg.actuators if isinstance(cfg.actuators, Actuators) else None
        args = (point.box, cfg.envelope, point.tube, point.current, act)
        for label, fn in (("bandwidth family", design_robust), ("LMI synthesis", synthesise_robust)):
            t, design = _timed_design(fn, *args)
            cert = design.certificate  # type: ignore[attr-defined]
            g: Gains = design.gains  # type: ignore[attr-defined]
            peak = cert.thrust.as_tuple() if cert.thrust is not None else (float("nan"),) * 3
            limits = "none" if act is None else ", ".join(f"{x:g}" for x in act.limits())
            rows.append(
                [
                    f"`{name}` ({cfg.n} vehicles)",
                    label,
                    f"{t:.2f}",
                    f"{g.alpha:.3g}, {g.k1:.3g}",
                    ", ".join(f"{x:,.0f}" for x in peak[:2]) + f", {peak[2]:.3g}",
                    limits,
                    "yes" if cert.covers else "no",
                ]
            )
    return table(
        f"6. Robust design time and certified peak force (medians of {REPEATS}; one core)",
        ["fleet", "design", "time [s]", "alpha, k1", "certified peak [N, N, N m]", "limits [N, N, N m]", "covers"],
        rows,
        "Both designs are certified by the same robust certificate on the declared box and current. "
        "`covers` is false when no candidate fits the actuator limits: certify then answers with the "
        "largest certifiable box and current. The REMUS is designed without limits: it has a propeller and a "
        "rudder, and certify refuses the fully actuated law on it.",
    )


if __name__ == "__main__":
    print(synthesis())
