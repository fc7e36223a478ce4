"""Error types: every failure a user can cause names the file (or key) and what is wrong."""

from __future__ import annotations


class SdovonError(Exception):
    """Base of the errors the command line reports as one line (exit code 1)."""


class InputError(SdovonError, ValueError):
    """Bad input data: names the file and the cause."""

    def __init__(self, path: object, cause: str) -> None:
        self.path = str(path)
        self.cause = cause
        super().__init__(f"{self.path}: {cause}")


class StageError(SdovonError, RuntimeError):
    """A pipeline stage that could not produce its output."""
