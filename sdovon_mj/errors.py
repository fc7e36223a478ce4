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


class UsageError(SdovonError):
    """A usage error found before any work (bad config value, missing or unreadable input): exit code 2."""


class InputsError(UsageError, InputError):
    """One or more input files that cannot be used, each named with its cause (checked before any work)."""

    def __init__(self, problems: list[tuple[str, str]]) -> None:
        self.problems = list(problems)
        path, cause = self.problems[0]
        InputError.__init__(self, path, cause)
        if len(self.problems) > 1:
            self.args = ("; ".join(f"{p}: {c}" for p, c in self.problems),)


class RunLockedError(UsageError):
    """The run folder is being written by another live process (named in the message)."""


class RendererError(SdovonError, RuntimeError):
    """The OpenGL renderer asked for is not the one this process can draw with (`sdovon_mj.gl`)."""
