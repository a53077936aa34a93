"""All benchmarks: prints the tables and rewrites ``benchmarks/README.md``.

Run with ``make bench`` (about 8-10 minutes on 2 cores). BLAS is pinned to one thread
before numpy is imported, so the timings measure the algorithms, not BLAS threading.
Every time is the median of at least 3 runs unless a table says otherwise; ratios are
against peers measured in the same run.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import datetime as dt  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from bench_design import gains, rhs_peers  # noqa: E402
from bench_sim import campaign_throughput, end_to_end, time_vs_error  # noqa: E402


def machine() -> str:
    """CPU model, cores, versions and date."""
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"Measured {dt.date.today().isoformat()} on {model} ({os.cpu_count()} cores visible, {platform.machine()}), "
        f"{platform.python_implementation()} {platform.python_version()}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}. BLAS threads pinned to 1 (OMP_NUM_THREADS = OPENBLAS_NUM_THREADS = MKL_NUM_THREADS = 1, "
        "set before numpy is imported). Product accuracy rtol = atol = 1e-8; reference solutions at rtol = atol = "
        "1e-11. Times are medians of >= 3 runs unless stated; ratios are against peers measured in the same run. "
        "The machine was shared with other jobs, so absolute times are noisy; ratios less so."
    )


def main() -> None:
    t0 = time.perf_counter()
    sections = []
    for fn in (gains, rhs_peers, time_vs_error, campaign_throughput, end_to_end):
        t = time.perf_counter()
        text = fn()
        print(text, flush=True)
        print(f"[{fn.__name__}: {time.perf_counter() - t:.0f} s]\n", flush=True)
        sections.append(text)
    order = [4, 2, 3, 0, 1]  # tables 1..5 in the README
    total = time.perf_counter() - t0
    head = f"# Benchmarks\n\n{machine()}\n\nRegenerate with `make bench` (this run: {total / 60:.1f} minutes).\n"
    Path(__file__).with_name("README.md").write_text(head + "\n" + "\n".join(sections[i] for i in order))
    print(f"README written; total {total:.0f} s")


if __name__ == "__main__":
    main()
