"""Monte Carlo campaigns: many perturbed runs of one configuration, batched, serial or on Dask.

A campaign samples ``K`` scenarios around the nominal certified situation (every vehicle
exactly on the raw mission at ``t = 0``) and integrates them in chunks, each chunk one
:class:`~auv_hinf.simulation.scenario.ScenarioBatch` (one step size per scenario). Per run ``i``:

* start errors of every vehicle against the raw mission at ``t = 0``, inside the certified
  simultaneous start region (:attr:`RegionCertificate.region <auv_hinf.closed_loop.region.RegionCertificate>`):
  position and velocity errors with magnitude uniform on ``[0, radius)`` and direction
  uniform on the circle, heading and yaw-rate errors uniform on ``(-radius, radius)``; the
  state is built from the mission's motion at ``t = 0`` (body velocities ``R(psi)^T (v - c)``);
* plant multipliers uniform in the ``[uncertainty]`` box (1 for undeclared parameters);
* a constant current uniform in the disc ``|c| <= [disturbance] current_speed`` (default 0).

Random numbers of run ``i`` come from ``SeedSequence(seed, spawn_key=(i,))`` (the ``i``-th
child of ``SeedSequence(seed).spawn``), so the sampled inputs depend on neither the chunking
nor the executor. The integrated numbers are identical for the same chunk size on any
executor; with another chunk size they agree to round-off (the integrator's per-system
step control does not couple the scenarios of a batch, only BLAS round-off may differ).

When a box or a current is declared and the robust certificate covers them, the start errors,
plants and currents are drawn as :mod:`auv_hinf.campaign.starts` says (inside the robust
invariant sets, box vertices on every other run) and every run is checked against the robust bounds.
Otherwise the nominal certificate bounds a run only when its plant is nominal and there is no
current; elsewhere ``inside_bounds`` is NA. Every run also records its peak commanded force per
channel before saturation, checked (``within_certified_force``) against the thrust bound of
the certificate that applies to it.
:mod:`auv_hinf.campaign.report` writes the table, the summary and the histograms.
"""

from __future__ import annotations

import logging
import math
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from auv_hinf.campaign.runs import run_chunk
from auv_hinf.campaign.setup import CampaignSetup, chunks, default_chunk, prepare
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import Interrupted, ParameterError


@dataclass(frozen=True)
class Campaign:
    """Result of :func:`run_campaign`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per run, ordered by run index (columns: see :func:`run_chunk`).
    setup : CampaignSetup
    certificate : ClosedLoopCertificate or None
        The nominal certificate (``None`` with integral action: the robust one covers it).
    chunk : int
    executor : str
        ``"serial"`` or the Dask scheduler address.
    setup_time, wall_time : float
        Design + certification time and the time of the runs (s, wall clock).
    requested : int or None
        The runs asked for, when fewer finished (an interrupted campaign); ``None``: all of them.
    """

    table: pd.DataFrame
    setup: CampaignSetup
    certificate: ClosedLoopCertificate | None
    chunk: int
    executor: str
    setup_time: float
    wall_time: float
    requested: int | None = None

    @property
    def interrupted(self) -> bool:
        """Fewer runs finished than were asked for (Ctrl-C)."""
        return self.requested is not None and len(self.table) < self.requested


def run_campaign(
    cfg: FormationConfig,
    runs: int,
    *,
    seed: int = 0,
    chunk: int | None = None,
    horizon: float | None = None,
    client: Any = None,
    progress: bool = False,
) -> Campaign:
    """Sample and run ``runs`` scenarios of ``cfg`` (see the module docstring).

    Parameters
    ----------
    cfg : FormationConfig
    runs : int
        Number of runs ``K >= 1``.
    seed : int
        Root seed (>= 0).
    chunk : int, optional
        Scenarios per batch (default :func:`default_chunk`, reduced on Dask so that every worker
        gets a chunk).
    horizon : float, optional
        Simulated time (s); default ``cfg.simulation.horizon``.
    client : distributed.Client, optional
        Run one task per chunk on this Dask client; default: in-process, serially.
    progress : bool
        Show a tqdm progress bar (stderr) over the runs.

    Raises
    ------
    ParameterError
        For bad ``runs``, ``chunk``, ``seed`` or ``horizon``.
    DesignError
        If the design has no closed-loop certificate.
    Interrupted
        On Ctrl-C (SIGINT) during the runs: its ``partial`` is the :class:`Campaign` of the chunks
        that finished (``requested`` set), or ``None`` when none did.
    """
    for name, val in (("runs", runs), ("chunk", chunk)):
        if val is not None and (isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 1):
            raise ParameterError(f"{name} must be an integer >= 1, got {val!r}")
    t0 = time.perf_counter()
    setup, cert = prepare(cfg, seed=seed, horizon=horizon)
    size = int(chunk) if chunk is not None else _balanced(default_chunk(setup), int(runs), client)
    t1 = time.perf_counter()
    parts, stopped = _execute(setup, chunks(int(runs), size), client, progress)
    wall = time.perf_counter() - t1
    executor = "serial" if client is None else f"dask {getattr(client.scheduler, 'address', client)}"
    if not parts:
        raise Interrupted(0, int(runs))
    table = pd.concat(parts, ignore_index=True).sort_values("run", ignore_index=True)
    for col in ("inside_bounds", "within_certified_force"):
        table[col] = table[col].astype("boolean")
    camp = Campaign(table, setup, cert, size, executor, t1 - t0, wall, int(runs) if stopped else None)
    if stopped:
        raise Interrupted(len(table), int(runs), camp)
    return camp


def _balanced(size: int, runs: int, client: Any) -> int:
    """``size``, reduced so that the chunks split evenly over the workers of ``client``.

    The number of chunks is rounded up to a multiple of the number of workers and the runs
    are spread evenly over them, so no worker idles while another runs a last chunk.
    """
    if client is None or runs <= 0:
        return size
    workers = max(1, len(client.scheduler_info().get("workers", {})))
    n_chunks = workers * math.ceil(math.ceil(runs / size) / workers)
    return max(1, math.ceil(runs / n_chunks))


def _execute(
    setup: CampaignSetup, ranges: list[tuple[int, int]], client: Any, progress: bool
) -> tuple[list[pd.DataFrame], bool]:
    """Run the chunks in order (serially) or one Dask task per chunk; the finished chunks, and whether Ctrl-C
    stopped them.

    The bar counts runs: a chunk moves it by its runs times the fraction of its samples
    produced so far (:class:`ChunkProgress` on Dask), so it moves as the runs progress and
    ends at the number of runs. On Dask the result of each chunk is fetched as soon as it
    finishes, so a Ctrl-C (which also reaches the local workers) keeps every finished chunk.
    """
    from tqdm import tqdm

    total = ranges[-1][1] if ranges else 0
    out: dict[int, pd.DataFrame] = {}  # finished chunks by their first run
    with tqdm(total=total, unit="run", disable=not progress, desc="campaign") as bar:
        try:
            if client is None:
                for lo, hi in ranges:
                    start = bar.n

                    def advance(done: float, lo: int = lo, hi: int = hi, start: int = start) -> None:
                        bar.update(start + int(done * (hi - lo)) - bar.n)  # a chunk moves the bar as it runs

                    out[lo] = run_chunk(setup, lo, hi, progress=advance)
                    bar.update(start + (hi - lo) - bar.n)
            else:
                _execute_dask(setup, ranges, client, bar, out)
        except KeyboardInterrupt:
            return [out[lo] for lo in sorted(out)], True
    return [out[lo] for lo in sorted(out)], False


def _execute_dask(
    setup: CampaignSetup, ranges: list[tuple[int, int]], client: Any, bar: Any, out: dict[int, pd.DataFrame]
) -> None:
    """One Dask task per chunk; each finished chunk's table goes into ``out`` (by its first run) at once."""
    remote = client.scatter(setup, broadcast=True)
    topic = f"auv-hinf-campaign-{uuid.uuid4().hex}"
    futures = {
        lo: client.submit(run_chunk, remote, lo, hi, progress=ChunkProgress(topic, lo), pure=False) for lo, hi in ranges
    }
    done = dict.fromkeys(futures, 0.0)  # fraction of each chunk's samples produced
    while len(out) < len(ranges):
        for _, (lo, frac) in client.get_events(topic):
            done[lo] = max(done[lo], float(frac))
        for lo, fut in futures.items():
            if lo not in out and fut.done():
                out[lo] = fut.result()
                done[lo] = 1.0
        bar.update(sum(int(done[lo] * (hi - lo)) for lo, hi in ranges) - bar.n)
        if len(out) < len(ranges):
            time.sleep(PROGRESS_POLL)


#: Seconds between two looks at the workers' progress events of a Dask campaign.
PROGRESS_POLL = 0.2


@dataclass(frozen=True)
class ChunkProgress:
    """``progress`` of :func:`run_chunk` on a Dask worker: each fraction becomes an event on ``topic``.

    The client reads them (``Client.get_events``) and moves the bar as the chunk runs, as the
    serial path does, instead of once per finished chunk.

    Attributes
    ----------
    topic : str
        Name of the Dask event topic.
    lo : int
        First run index of the chunk, sent with each fraction.
    """

    topic: str
    lo: int

    def __call__(self, done: float) -> None:
        from distributed import get_worker

        get_worker().log_event(self.topic, (self.lo, float(done)))


#: glibc allocator settings of local Dask workers (set before they start). Dask's default
#: ``MALLOC_TRIM_THRESHOLD_=65536`` also switches off glibc's adaptive mmap threshold, so
#: every temporary array above 128 kB is mapped and unmapped again: the batched integrator
#: then spends most of its time in page faults (measured on 2 workers: 30k vehicle-seconds
#: per second with Dask's default, 70k with these). These keep temporaries of up to 32 MiB on
#: the heap and trim it only past 256 MiB free. Workers of an external cluster
#: (``--scheduler``) need the same two environment variables.
WORKER_MALLOC = {"MALLOC_TRIM_THRESHOLD_": 2**28, "MALLOC_MMAP_THRESHOLD_": 2**25}


def _not_a_cancelled_chunk(record: logging.LogRecord) -> bool:
    """Log filter: drop Dask's warning that a cancelled task ended (the chunks Ctrl-C abandoned)."""
    return "ended with CancelledError" not in record.getMessage()


def dask_setup(worker: Any) -> None:
    """Start-up of a local Dask worker (a preload): it ignores SIGINT and keeps quiet about cancelled chunks.

    Ctrl-C in a terminal reaches every process of the group. The client alone stops: it keeps
    the finished chunks and closes the cluster, which abandons the others; a worker stopping by
    itself would print its own traceback, and one whose chunk is abandoned a warning per chunk.

    Parameters
    ----------
    worker : distributed.Worker
        The worker starting (unused).
    """
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.getLogger("distributed.worker.state_machine").addFilter(_not_a_cancelled_chunk)


@contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client: a local cluster of ``workers`` single-threaded processes, or ``scheduler``.

    Closes what it opened.

    Parameters
    ----------
    workers : int, optional
        Number of worker processes of a local cluster (>= 1).
    scheduler : str, optional
        Address of a running Dask scheduler to connect to.

    Yields
    ------
    distributed.Client or None
        The client; ``None`` (in-process, serial) when neither is given.

    Raises
    ------
    ParameterError
        If both are given, ``workers < 1``, or the scheduler cannot be reached.
    """
    if workers is not None and scheduler is not None:
        raise ParameterError("give either workers or a scheduler address, not both")
    if workers is None and scheduler is None:
        yield None
        return
    import dask
    from distributed import Client, LocalCluster

    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
        environ = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_MALLOC.items()}
        # dashboard_address ":0": any free port for the scheduler's HTTP server. None means the
        # default 8787, and a second cluster on the machine (parallel tests, another campaign)
        # then fails to start with "Port 8787 is already in use".
        with (
            dask.config.set(environ),
            LocalCluster(  # type: ignore[no-untyped-call]
                n_workers=workers, threads_per_worker=1, dashboard_address=":0", preload=[__name__]
            ) as cluster,
            Client(cluster) as client,  # type: ignore[no-untyped-call]
        ):
            yield client
        return
    try:
        client = Client(scheduler, timeout="10s")  # type: ignore[no-untyped-call]
    except (OSError, TimeoutError, ValueError) as exc:
        raise ParameterError(f"cannot connect to the Dask scheduler {scheduler!r}: {exc}") from None
    with client:
        yield client


__all__ = ["PROGRESS_POLL", "WORKER_MALLOC", "Campaign", "ChunkProgress", "dask_client", "dask_setup", "run_campaign"]
