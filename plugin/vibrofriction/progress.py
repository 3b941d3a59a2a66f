"""One progress report for long runs (sweeps, the study's stages): ``progress(done, total)``.

On a terminal, a bar redrawn in place with the time left; in a redirected log (no terminal), a
plain line at every tenth of the work, so the log holds no carriage returns and stays short.
The time left is the elapsed time scaled by the work still to do.
"""
from __future__ import annotations

import sys
import time
from typing import Callable, TextIO

BAR_WIDTH = 30
LOG_STEPS = 10  # a redirected log gets a line when the first item is done, then every tenth


def progress_bar(label: str, stream: TextIO | None = None, indent: str = ""
                 ) -> Callable[[int, int], None]:
    """A ``progress(done, total)`` callback writing to ``stream`` (default stderr)."""
    out = stream if stream is not None else sys.stderr
    terminal = bool(getattr(out, "isatty", lambda: False)())
    started = time.monotonic()
    logged = [-1]  # last tenth written to a log

    def report(done: int, total: int) -> None:
        total = max(total, 1)
        elapsed = time.monotonic() - started
        left = elapsed * (total - done) / done if done > 0 else None
        timing = f"{elapsed:.0f} s" + (f", {left:.0f} s left" if left is not None and
                                       done < total else "")
        if terminal:
            filled = int(BAR_WIDTH * done / total)
            print(f"\r{indent}{label} [{'#' * filled}{'.' * (BAR_WIDTH - filled)}] "
                  f"{done}/{total} ({timing})", end="\n" if done >= total else "", file=out,
                  flush=True)
            return
        step = LOG_STEPS * done // total
        if step > logged[0]:
            logged[0] = step
            print(f"{indent}{label}: {done}/{total} ({timing})", file=out, flush=True)

    return report
