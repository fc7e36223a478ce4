"""Progress reporting: a tqdm bar on a terminal, sparse plain lines in non-interactive logs."""

from __future__ import annotations

import sys
import time
from typing import Any


class Progress:
    """A progress bar that degrades to one line per ~10 % when stderr is not a terminal."""

    def __init__(self, total: int, desc: str = "", enabled: bool | None = None) -> None:
        self.total = int(total)
        self.desc = desc
        self.n = 0
        self.interactive = sys.stderr.isatty() if enabled is None else bool(enabled) and sys.stderr.isatty()
        self.quiet = enabled is False
        self._bar: Any = None
        self._last_pct = -1
        self._t0 = time.perf_counter()

    def __enter__(self) -> "Progress":
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
            el = time.perf_counter() - self._t0
            print(f"[{self.desc}] {self.n}/{self.total} ({el:.0f}s) {note}", file=sys.stderr, flush=True)

    def __exit__(self, *exc: Any) -> None:
        if self._bar is not None:
            self._bar.close()
