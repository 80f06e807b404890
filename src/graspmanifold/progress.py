"""Progress reports for long jobs: one line that updates in a terminal, sparse lines in a log."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Counts finished units of work and reports `label: done/total unit (pct) elapsed, eta`.

    Disabled progress costs one comparison per update, so it can be left in hot loops.
    """

    def __init__(self, total: int, label: str, unit: str = "", *, enabled: bool = True,
                 stream: TextIO | None = None, min_interval: float = 0.5):
        self.total = max(int(total), 1)
        self.label, self.unit = label, unit
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.min_interval = min_interval
        self.done = 0
        self._start = time.perf_counter()
        self._last = -float("inf")
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled:
            return
        now = time.perf_counter()
        if self.done >= self.total or now - self._last >= (self.min_interval if self._tty else 10.0):
            self._last = now
            self._write(now)

    def _write(self, now: float) -> None:
        elapsed = now - self._start
        rate = self.done / elapsed if elapsed > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("nan")
        text = (f"{self.label}: {self.done}/{self.total} {self.unit} ({100 * self.done / self.total:.0f}%) "
                f"{elapsed:.1f} s, eta {eta:.1f} s")
        end = "\n" if self.done >= self.total or not self._tty else ""
        self.stream.write(("\r" if self._tty else "") + text + end)
        self.stream.flush()
