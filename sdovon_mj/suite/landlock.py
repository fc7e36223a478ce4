"""Landlock (Linux >= 5.13): seal an agent process's file system to an allow-list before any agent code runs.

This file is also the sealing launcher of the sealed evaluation (`launch`): `protocol.SealedSession` starts
``python -I -S <this file> SOCKET_FD FRAMES_FD``, which imports nothing but the standard library (``-S``: no
site-packages, no ``.pth`` file runs), receives the allow-list, calls `restrict`, answers, and only then execs the
agent's interpreter (``python -I -m sdovon_mj.suite.agent_process``). So the agent's interpreter starts sealed:
its ``site`` start-up, every ``.pth`` file and ``sitecustomize`` of its site-packages run under the seal. From then
on the process (and every process it starts) can read only the trees it was given (the Python installation,
site-packages, the package directories the agent imports, the embedding cache) and write only its scratch folder
(not ``/dev/shm``, not the caches: nothing it writes outlives it); opening anything else (the dataset's
``episodes.json``, ``/proc/<evaluator>/cmdline``) raises ``PermissionError``.
Landlock also confines ptrace (no reading ``/proc/<evaluator>/mem``) and, from ABI 6, signals and abstract
unix sockets to the process's own domain. Plain ctypes over the three system calls; no dependency.
"""

from __future__ import annotations

import ctypes
import os
import stat
import sys
from dataclasses import dataclass
from pathlib import Path

# System call numbers (the same on x86-64 and arm64: the generic table) and constants of linux/landlock.h.
_SYS_CREATE_RULESET, _SYS_ADD_RULE, _SYS_RESTRICT_SELF = 444, 445, 446
_CREATE_RULESET_VERSION = 1
_RULE_PATH_BENEATH = 1
_PR_SET_NO_NEW_PRIVS = 38

EXECUTE, WRITE_FILE, READ_FILE, READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
REMOVE_DIR, REMOVE_FILE, MAKE_CHAR, MAKE_DIR = 1 << 4, 1 << 5, 1 << 6, 1 << 7
MAKE_REG, MAKE_SOCK, MAKE_FIFO, MAKE_BLOCK, MAKE_SYM = 1 << 8, 1 << 9, 1 << 10, 1 << 11, 1 << 12
REFER, TRUNCATE, IOCTL_DEV = 1 << 13, 1 << 14, 1 << 15  # ABI 2, 3, 5
SCOPE_ABSTRACT_UNIX_SOCKET, SCOPE_SIGNAL = 1 << 0, 1 << 1  # ABI 6

READ = EXECUTE | READ_FILE | READ_DIR
_FILE_ONLY = EXECUTE | WRITE_FILE | READ_FILE | TRUNCATE | IOCTL_DEV  # the rights a rule on a file may carry


def _all_fs(abi: int) -> int:
    """Return every file-system access right the ABI knows (the ones the ruleset handles)."""
    rights = (1 << 13) - 1
    if abi >= 2:
        rights |= REFER
    if abi >= 3:
        rights |= TRUNCATE
    if abi >= 5:
        rights |= IOCTL_DEV
    return rights


class _RulesetAttr(ctypes.Structure):
    _fields_ = [("handled_access_fs", ctypes.c_uint64), ("handled_access_net", ctypes.c_uint64),
                ("scoped", ctypes.c_uint64)]


class _PathBeneathAttr(ctypes.Structure):
    _pack_ = 1  # linux/landlock.h declares it __attribute__((packed))
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


def _libc() -> ctypes.CDLL:
    libc = ctypes.CDLL(None, use_errno=True)
    libc.syscall.restype = ctypes.c_long
    return libc


def abi_version() -> int:
    """Return the kernel's Landlock ABI version (0: unavailable: not Linux, kernel too old, or disabled)."""
    if not sys.platform.startswith("linux"):
        return 0
    try:
        v = _libc().syscall(_SYS_CREATE_RULESET, None, ctypes.c_size_t(0), ctypes.c_uint32(_CREATE_RULESET_VERSION))
    except (OSError, AttributeError):
        return 0
    return int(v) if v > 0 else 0


@dataclass(frozen=True)
class Seal:
    """What sealed the agent's process: whether the file system was restricted, the ABI, and why not."""

    sealed: bool
    abi: int = 0
    reason: str = ""

    def describe(self) -> str:
        """Return the line result tables print."""
        if self.sealed:
            return f"file system sealed (Landlock ABI {self.abi})"
        return f"file system NOT sealed ({self.reason})"


def restrict(read: list[str | Path], write: list[str | Path], scope: bool = True) -> Seal:
    """Restrict this process (and its future children) to reading `read` and reading + writing `write` trees.

    Paths that do not exist are skipped. Returns the `Seal`; with Landlock unavailable nothing is restricted and
    the reason says so. Raises OSError when the kernel refuses a ruleset it claimed to support.

    Parameters
    ----------
    read : list of path
        Files and folders (whole trees) the process may read and execute.
    write : list of path
        Files and folders it may also write, create in and remove from (scratch, shared caches, /dev/shm).
    scope : bool
        From ABI 6: also forbid signals and abstract unix sockets towards processes outside the domain.
    """
    abi = abi_version()
    if abi <= 0:
        return Seal(False, 0, "Landlock unavailable on this kernel")
    libc = _libc()
    handled = _all_fs(abi)
    attr = _RulesetAttr(handled, 0, (SCOPE_ABSTRACT_UNIX_SOCKET | SCOPE_SIGNAL) if (scope and abi >= 6) else 0)
    size = ctypes.sizeof(_RulesetAttr) if abi >= 6 else 16 if abi >= 4 else 8
    fd = libc.syscall(_SYS_CREATE_RULESET, ctypes.byref(attr), ctypes.c_size_t(size), ctypes.c_uint32(0))
    if fd < 0:
        raise OSError(ctypes.get_errno(), "landlock_create_ruleset failed")
    try:
        for paths, rights in ((read, READ), (write, handled)):
            for p in paths:
                _add(libc, fd, Path(p), rights & handled)
        if libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_NO_NEW_PRIVS) failed")
        if libc.syscall(_SYS_RESTRICT_SELF, ctypes.c_int(fd), ctypes.c_uint32(0)) != 0:
            raise OSError(ctypes.get_errno(), "landlock_restrict_self failed")
    finally:
        os.close(fd)
    return Seal(True, abi)


def _add(libc: ctypes.CDLL, ruleset: int, path: Path, rights: int) -> None:
    """Add one path-beneath rule (a file gets only the rights a file can carry)."""
    try:
        pfd = os.open(str(path), os.O_PATH | os.O_CLOEXEC)
    except OSError:
        return  # absent: nothing to allow
    try:
        if not stat.S_ISDIR(os.fstat(pfd).st_mode):
            rights &= _FILE_ONLY
        rule = _PathBeneathAttr(rights, pfd)
        if libc.syscall(_SYS_ADD_RULE, ctypes.c_int(ruleset), ctypes.c_int(_RULE_PATH_BENEATH), ctypes.byref(rule),
                        ctypes.c_uint32(0)) != 0:
            raise OSError(ctypes.get_errno(), f"landlock_add_rule failed for {path}")
    finally:
        os.close(pfd)


def launch(argv: list[str]) -> int:
    """The sealing launcher (``python -I -S landlock.py SOCKET_FD FRAMES_FD``): seal, answer, exec the agent process.

    Receives ``{"read", "write", "seal"}`` as one JSON message on the socket (the framing of
    ``multiprocessing.connection``), restricts this process when ``seal`` is true, answers ``{"sealed", "abi",
    "reason"}`` and execs ``python -I -m sdovon_mj.suite.agent_process`` with the same two descriptors.
    """
    import json
    from multiprocessing.connection import Connection

    sock, frames = int(argv[0]), int(argv[1])
    conn = Connection(sock)
    plan = json.loads(conn.recv_bytes(1 << 24).decode("utf-8"))
    if plan.get("seal"):
        try:
            seal = restrict(list(plan["read"]), list(plan["write"]))
        except OSError as e:
            seal = Seal(False, 0, f"Landlock refused the ruleset: {e}")
    else:
        seal = Seal(False, 0, "sealing was switched off")
    conn.send_bytes(json.dumps({"sealed": seal.sealed, "abi": seal.abi, "reason": seal.reason}).encode("utf-8"))
    os.set_inheritable(sock, True)
    os.set_inheritable(frames, True)
    os.execv(sys.executable, [sys.executable, "-I", "-m", "sdovon_mj.suite.agent_process", str(sock), str(frames)])
    return 1  # not reached: execv replaces this process


__all__ = ["Seal", "abi_version", "launch", "restrict", "READ"]


if __name__ == "__main__":
    sys.exit(launch(sys.argv[1:]))
