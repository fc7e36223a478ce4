"""Shared test fixtures: paths to the shared third-party assets, offscreen GL; no silent skips under CI."""

from __future__ import annotations

import os
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")

REPO = Path(__file__).resolve().parents[1]
SHARED_ASSETS = Path(os.environ.get("SDOVON_SHARED_ASSETS", REPO.parent / "shared" / "assets"))

# Skips that CI accepts: test node id -> why it cannot run on CI's machine. Any other skip (a skipif mark,
# pytest.skip in a test or fixture, a module-level importorskip) fails the run when CI=true, with its reason.
# Keep this empty.
ACCEPTED_SKIPS: dict[str, str] = {}


@pytest.fixture(scope="session")
def shared_assets() -> Path:
    """The third-party assets folder (../shared/assets); skips when absent."""
    if not (SHARED_ASSETS / "MANIFEST.json").exists():
        pytest.skip(f"shared assets not found at {SHARED_ASSETS}")
    return SHARED_ASSETS


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def _fail_unaccepted_skip(report: pytest.CollectReport | pytest.TestReport) -> None:
    """Turn a skip report into a failure naming the skip's reason, unless ACCEPTED_SKIPS lists the node."""
    if not report.skipped or hasattr(report, "wasxfail") or report.nodeid in ACCEPTED_SKIPS:
        return
    lr = report.longrepr
    reason = (lr[2] if isinstance(lr, tuple) and len(lr) == 3 else str(lr)).removeprefix("Skipped: ")
    report.outcome = "failed"
    report.longrepr = f"skipped under CI=true (not in tests/conftest.py ACCEPTED_SKIPS): {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, Any, None]:
    """Under CI=true, a skipped test (skipped in setup or in its body) fails with its reason."""
    outcome = yield
    if _in_ci():
        _fail_unaccepted_skip(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Generator[None, Any, None]:
    """Under CI=true, a module skipped at collection (importorskip, allow_module_level) fails with its reason."""
    outcome = yield
    if _in_ci():
        _fail_unaccepted_skip(outcome.get_result())
