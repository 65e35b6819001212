"""A tiny progress bar on stderr (tqdm is not a dependency)."""

from __future__ import annotations

import sys
import time


def _clock(seconds: float) -> str:
    m, s = divmod(int(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:d}:{s:02d}"


class Progress:
    """``total`` steps; ``step(label)`` after each. On a terminal the bar redraws in place; into
    a file or pipe it writes a line at most every ``every_s`` seconds (and the last one)."""

    def __init__(self, total: int, stream=None, width: int = 28, every_s: float = 5.0):
        self.total = max(int(total), 1)
        self.done = 0
        self.stream = stream or sys.stderr
        self.width = width
        self.every_s = every_s
        self.start = time.perf_counter()
        self._last = -1e9
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.label = ""
        self._drawn = None

    def add(self, n: int) -> None:
        """More steps than planned."""
        self.total += int(n)

    def step(self, label: str = "", n: int = 1) -> None:
        self.done = min(self.done + n, self.total)
        self.label = label
        self.draw(force=self.done >= self.total)

    def note(self, label: str) -> None:
        """Show what runs now without counting a step."""
        self.label = label
        self.draw()

    def draw(self, force: bool = False) -> None:
        now = time.perf_counter()
        if not (self._tty or force or now - self._last >= self.every_s):
            return
        if (self.done, self.label) == self._drawn and not self._tty:
            return
        self._drawn = (self.done, self.label)
        self._last = now
        frac = self.done / self.total
        filled = int(round(frac * self.width))
        elapsed = now - self.start
        eta = f" eta {_clock(elapsed / frac - elapsed)}" if 0 < frac < 1 else ""
        line = (f"[{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:3.0f}% "
                f"{self.done}/{self.total} {_clock(elapsed)}{eta}  {self.label}")
        if self._tty:
            self.stream.write("\r" + line[:150].ljust(150))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def log(self, message: str) -> None:
        """A line of text that does not break the bar."""
        if self._tty:
            self.stream.write("\r" + " " * 150 + "\r")
        self.stream.write(message + "\n")
        self.draw(force=self._tty)

    def close(self) -> None:
        self.draw(force=True)
        if self._tty:
            self.stream.write("\n")
        self.stream.flush()
