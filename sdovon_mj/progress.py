"""Progress reporting: a tqdm bar on a terminal, sparse plain lines (done of total, elapsed, ETA) in
non-interactive logs.

A quiet bar (``enabled=False``, e.g. ``generate --quiet``) silences the bars opened inside it (``enabled=None``),
also in the worker processes started meanwhile: the choice travels in the environment (`QUIET_ENV`), the one
channel a spawned worker shares with its parent besides the task it is sent.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

QUIET_ENV = "SDOVON_QUIET_PROGRESS"  # "1" while a quiet bar is open: bars opened inside it stay quiet too


class Progress:
    """A progress bar that degrades to one line per ~10 % (with an ETA) when stderr is not a terminal.

    ``enabled``: True shows it (a bar on a terminal, lines otherwise), False silences it and the bars opened
    inside it, None shows it unless an enclosing bar is quiet.
    """

    def __init__(self, total: int, desc: str = "", enabled: bool | None = None) -> None:
        self.total = int(total)
        self.desc = desc
        self.n = 0
        self.quiet = enabled is False or (enabled is None and os.environ.get(QUIET_ENV) == "1")
        self.interactive = not self.quiet and sys.stderr.isatty()
        self._bar: Any = None
        self._last_pct = -1
        self._t0 = time.perf_counter()
        self._env_before: str | None = None

    def __enter__(self) -> "Progress":
        if self.quiet:
            self._env_before = os.environ.get(QUIET_ENV)
            os.environ[QUIET_ENV] = "1"
        if self.interactive:
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=self.desc, leave=True, dynamic_ncols=True)
        return self

    def update(self, n: int = 1, note: str = "") -> None:
        """Advance by `n` steps, showing `note` as the latest item."""
        self.n += n
        if self._bar is not None:
            self._bar.total = self.total
            self._bar.set_postfix_str(note[:40], refresh=False)
            self._bar.update(n)
            return
        if self.quiet or self.total <= 0:
            return
        pct = int(100 * self.n / self.total) // 10 * 10
        if pct != self._last_pct or self.n >= self.total:
            self._last_pct = pct
            print(self.line(note), file=sys.stderr, flush=True)

    def line(self, note: str = "") -> str:
        """Return the plain progress line: done of total, seconds so far, the ETA (from the mean time per step)."""
        el = time.perf_counter() - self._t0
        left = max(0, self.total - self.n)
        eta = f", ETA {el / self.n * left:.0f}s" if self.n and left else ""
        return f"[{self.desc}] {self.n}/{self.total} ({el:.0f}s{eta}) {note}".rstrip()

    def write(self, text: str) -> None:
        """Print a line of its own (above the bar on a terminal; nothing when quiet)."""
        if self._bar is not None:
            self._bar.write(text, file=sys.stderr)
        elif not self.quiet:
            print(text, file=sys.stderr, flush=True)

    def __exit__(self, *exc: Any) -> None:
        if self._bar is not None:
            self._bar.close()
        if self.quiet:
            if self._env_before is None:
                os.environ.pop(QUIET_ENV, None)
            else:
                os.environ[QUIET_ENV] = self._env_before
