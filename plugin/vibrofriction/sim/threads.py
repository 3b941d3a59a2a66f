"""How many CPUs this process may use: the default size of every thread pool."""
from __future__ import annotations

import os


def cpu_count() -> int:
    """CPUs this process may run on (its affinity on Linux, else os.cpu_count()), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)
