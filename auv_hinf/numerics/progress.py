"""When long work shows a progress bar: one delay for every bar of the package."""

from __future__ import annotations

#: Seconds before a progress bar appears: only slow work (a search, a long run) shows one.
PROGRESS_DELAY = 1.0

__all__ = ["PROGRESS_DELAY"]
