"""Signals: SIGTERM stops a run the way Ctrl-C does (`Interrupted`, a KeyboardInterrupt), so the run's cleanup
(workers stopped, temp files removed, the lock released) runs and finished stages are kept for a resume."""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Any, Iterator


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (SIGTERM, SIGINT); finished stages are kept for a resume."""

    def __init__(self, signum: int) -> None:
        self.exit_code = 128 + signum
        name = signal.Signals(signum).name
        super().__init__(f"stopped by {name}; finished stages are kept, run the same command again to resume")


def _raise_interrupted(signum: int, _frame: Any) -> None:
    """Signal handler: stop the run with `Interrupted` (temp files are removed, the lock released)."""
    raise Interrupted(signum)


@contextlib.contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """Within this block SIGTERM raises `Interrupted` (in the main thread only: elsewhere Python cannot set a
    handler, and the block changes nothing); the previous handler is restored after it."""
    in_main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGTERM, _raise_interrupted) if in_main else None
    try:
        yield
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, old)


__all__ = ["Interrupted", "sigterm_interrupts"]
