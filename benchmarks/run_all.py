"""Ratio benchmarks against peer methods, measured in the same run.

Run with ``make bench``. Prints tables of medians and ratios and rewrites
``benchmarks/README.md`` with the machine and the date.
"""

from __future__ import annotations

import datetime as dt
import platform
import statistics
import time
import tracemalloc
from pathlib import Path
from typing import Callable

import numpy as np

from auv_hinf.crosscheck import lmi_stabilizing_alpha, riccati_alpha
from auv_hinf.design import alpha_stabilizing
from auv_hinf.scenarios import paper_scenario
from auv_hinf.simulation import closed_loop_rhs
from auv_hinf.sweep import sigma_max_2x2
from auv_hinf.vehicle import paper2011, rhs

LAM, GAMMA = -1.2, 2.86


def median_time(fn: Callable[[], object], repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def table(title: str, header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in rows]
    return "\n".join([f"### {title}", "", line, sep, *body, ""])


def bench_gain() -> str:
    rows = []
    for n in (3, 10, 30, 100):
        exact = alpha_stabilizing(LAM, GAMMA).alpha
        t_cf = median_time(lambda: (lambda d: 1.0 / (d.alpha - LAM))(alpha_stabilizing(LAM, GAMMA)), 50)
        care = riccati_alpha(LAM, GAMMA, n)
        t_care = median_time(lambda: riccati_alpha(LAM, GAMMA, n), 3)
        if n <= 30:
            lmi = lmi_stabilizing_alpha(LAM, GAMMA, n)
            t_lmi = median_time(lambda: lmi_stabilizing_alpha(LAM, GAMMA, n), 1)
            lmi_cells = [f"{t_lmi * 1e3:.1f}", f"{t_lmi / t_cf:,.0f}x", f"{abs(lmi.value - exact) / exact:.1e}"]
        else:
            lmi_cells = ["skipped", "-", "-"]
        rows.append([str(n), f"{t_cf * 1e6:.1f}", f"{t_care * 1e3:.2f}", f"{t_care / t_cf:,.0f}x",
                     f"{abs(care.alpha - exact) / exact:.1e}", *lmi_cells])
    return table(
        "Gain certification: closed form vs full-size care and LMI (lambda=-1.2, gamma=2.86)",
        ["N", "closed form [us]", "control.care [ms]", "care / closed", "care rel err", "LMI [ms]", "LMI / closed", "LMI rel err"],
        rows,
    )


def bench_sigma() -> str:
    rng = np.random.default_rng(0)
    m = rng.normal(size=(1_000_000, 2, 2))
    t_cf = median_time(lambda: sigma_max_2x2(m), 3)
    t_np = median_time(lambda: np.linalg.norm(m, 2, axis=(-2, -1)), 1)
    err = float(np.max(np.abs(sigma_max_2x2(m) - np.linalg.norm(m, 2, axis=(-2, -1)))))
    return table(
        "sigma: closed-form 2x2 norm vs numpy.linalg.norm(..., 2), 1e6 stacked matrices",
        ["method", "time [ms]", "points/s", "ratio", "max abs diff"],
        [["closed form", f"{t_cf * 1e3:.1f}", f"{1e6 / t_cf:.3g}", "1x", f"{err:.1e}"],
         ["numpy norm 2", f"{t_np * 1e3:.1f}", f"{1e6 / t_np:.3g}", f"{t_np / t_cf:.1f}x slower", "-"]],
    )


def bench_simulation() -> str:
    params = paper2011()
    rows = []
    rng = np.random.default_rng(1)
    for n in (3, 30, 300, 1000):
        s = rng.normal(size=(n, 6))
        tau = rng.normal(size=(n, 3))
        t_vec = median_time(lambda: rhs(params, s, tau), 20)
        t_loop = median_time(lambda: [rhs(params, s[i], tau[i]) for i in range(n)], 3)
        rows.append([str(n), f"{t_vec * 1e6:.0f}", f"{t_loop * 1e6:.0f}", f"{t_loop / t_vec:.1f}x"])
    scn = paper_scenario("paper-triangle")
    y = scn.initial.ravel()
    t_cl = median_time(lambda: closed_loop_rhs(scn, 1.0, y), 50)
    out = table("Vehicle rhs: one vectorised call vs a per-vehicle Python loop",
                ["N", "vectorised [us]", "per-vehicle loop [us]", "ratio"], rows)
    tracemalloc.start()
    s = rng.normal(size=(1000, 6))
    rhs(params, s, rng.normal(size=(1000, 3)))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out + f"\nClosed-loop rhs of the paper triangle (controller + plant): {t_cl * 1e6:.0f} us per call. Peak traced memory of one N=1000 rhs: {peak / 1e6:.2f} MB.\n"


def main() -> None:
    sections = [bench_gain(), bench_sigma(), bench_simulation()]
    head = (f"# Benchmarks\n\nMeasured {dt.date.today().isoformat()} on {platform.machine()}, "
            f"{platform.python_implementation()} {platform.python_version()}, "
            f"{__import__('os').cpu_count()} cores. Ratios are taken in the same run. Regenerate with `make bench`.\n")
    text = head + "\n" + "\n".join(sections)
    print(text)
    Path(__file__).with_name("README.md").write_text(text)


if __name__ == "__main__":
    main()
