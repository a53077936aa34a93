"""Real-time priority for the loop and the loopback fleet, when the operating system grants it.

A fixed-rate loop on a shared computer is only as punctual as the scheduler lets it be: on two cores
with other jobs running, a step can be late by a hundred milliseconds, which the monitor rightly
reports as a broken ``lag`` or ``delay``. :func:`raise_priority` asks for the ``SCHED_FIFO`` policy
(Linux; it needs root or ``CAP_SYS_NICE``) and falls back to a lower nice value, then to nothing.
The loop sleeps in ``select`` most of the time (about 15 ms of work per 100 ms step for four
vehicles), and Linux caps real-time tasks at 95 % of a core by default
(``sched_rt_runtime_us``), so a real-time loop cannot lock up the machine.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

#: The ``SCHED_FIFO`` priority asked for (1-99): low, above every normal task and below the kernel's.
FIFO_PRIORITY = 10
#: The nice value asked for when real-time scheduling is refused.
NICE_VALUE = -10


def raise_priority() -> str:
    """Ask for real-time scheduling of the calling thread (and the threads it starts afterwards).

    Returns
    -------
    str
        ``"fifo"`` (granted), ``"nice"`` (a nice value of :data:`NICE_VALUE` instead) or
        ``"normal"`` (neither was allowed).
    """
    sched = getattr(os, "sched_setscheduler", None)
    if sched is not None:
        try:
            sched(0, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
            return "fifo"
        except (OSError, AttributeError):
            pass
    try:
        os.setpriority(os.PRIO_PROCESS, 0, NICE_VALUE)
        return "nice"
    except (OSError, AttributeError):
        return "normal"


@contextmanager
def realtime_priority(enabled: bool = True) -> Iterator[str]:
    """:func:`raise_priority` for the calling thread while the block runs, then its scheduling as before.

    Parameters
    ----------
    enabled : bool
        ``False`` leaves the scheduling alone (the block then sees ``"normal"``).

    Yields
    ------
    str
        What was granted (see :func:`raise_priority`).
    """
    if not enabled or not hasattr(os, "sched_getscheduler"):
        yield "normal"
        return
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    nice = os.getpriority(os.PRIO_PROCESS, 0)
    granted = raise_priority()
    try:
        yield granted
    finally:
        try:
            os.sched_setscheduler(0, policy, param)
            os.setpriority(os.PRIO_PROCESS, 0, nice)
        except OSError:  # an unprivileged thread may not raise its nice value back; it was never lowered then
            pass


__all__ = ["FIFO_PRIORITY", "NICE_VALUE", "raise_priority", "realtime_priority"]
