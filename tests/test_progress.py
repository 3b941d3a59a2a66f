"""Progress of long runs: a bar redrawn in place on a terminal, plain lines in a log."""
from __future__ import annotations

import io

from vibrofriction.progress import LOG_STEPS, progress_bar


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_a_line_per_tenth_and_no_carriage_returns():
    log = io.StringIO()
    report = progress_bar("sweep", log)
    for done in range(1, 101):
        report(done, 100)
    text = log.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert len(lines) == LOG_STEPS + 1  # the first item done, then every tenth
    assert lines[-1].startswith("sweep: 100/100 (") and "left" not in lines[-1]
    assert "s left)" in lines[0]


def test_a_terminal_gets_one_bar_redrawn_with_the_time_left():
    terminal = _Terminal()
    report = progress_bar("stage", terminal, indent="  ")
    for done in range(1, 5):
        report(done, 4)
    text = terminal.getvalue()
    assert text.count("\r") == 4 and text.endswith("\n") and text.count("\n") == 1
    assert "  stage [" + "#" * 30 + "] 4/4" in text
    assert "s left)" in text
