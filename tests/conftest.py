"""Shared test fixtures: paths to the shared third-party assets, offscreen GL; no silent skips under CI."""

from __future__ import annotations

import os
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest

import sdovon_mj  # noqa: F401  (first of the project: its numerics profile must be set before numpy loads)

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


# Session fixtures that generate a run: under pytest-xdist every module reading one of them runs on one worker.
SHARED_RUNS = ("tiny_export_run", "articulated_closed_run")
SLOW_COST = 30  # a slow-marked test counts as this many fast ones when groups are ordered (slow: more than ~20 s)


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook reads the groups into the node ids
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under pytest-xdist (``./run.sh test`` runs ``-n 2 --dist loadgroup``), group tests so that nothing expensive is
    built twice, and send the costliest groups first.

    A group is a test module (its module fixtures are built once, on one worker), and modules that read the same
    shared run (`SHARED_RUNS`) form one group. Groups go longest first, estimated from their slow marks: xdist hands
    them out in collection order (``--no-loadscope-reorder``), and a long test taken last would run alone at the end.
    Without xdist (a plain ``pytest``), nothing changes.
    """
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    parent: dict[str, str] = {}

    def find(x: str) -> str:
        while parent.setdefault(x, x) != x:
            x = parent[x]
        return x

    def module(item: pytest.Item) -> str:
        return item.nodeid.split("::")[0]

    for item in items:
        for name in SHARED_RUNS:
            if name in item.fixturenames:
                parent[find(module(item))] = find(name)
    group = {item.nodeid: find(module(item)) for item in items}
    cost: dict[str, int] = {}
    for item in items:
        item.add_marker(pytest.mark.xdist_group(group[item.nodeid]))
        cost[group[item.nodeid]] = cost.get(group[item.nodeid], 0) + (SLOW_COST if item.get_closest_marker("slow") else 1)
    first = {g: k for k, g in enumerate(dict.fromkeys(group.values()))}
    items.sort(key=lambda i: (-cost[group[i.nodeid]], first[group[i.nodeid]]))  # stable: a group's tests keep their order


@pytest.fixture(scope="session")
def tiny_export_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny generated run of tests/sim_export_run.py (1 apartment, 2 variants), once per session: the USD, URDF
    and Genesis export tests read the same run (each exports it itself)."""
    from sim_export_run import tiny_run

    return tiny_run(tmp_path_factory.mktemp("tiny"))


@pytest.fixture(scope="session")
def articulated_closed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny articulated default-world run (every part closed; tests/test_articulated_pipeline.py's CONFIG) to its
    episodes, exported as MJCF bundles: ``<root>/run`` and ``<root>/mjcf``. One run shared by the pipeline and suite tests.
    """
    import os
    import subprocess
    import sys

    from test_articulated_pipeline import CONFIG

    root = tmp_path_factory.mktemp("art_closed")
    cfg = root / "art.yaml"
    cfg.write_text(CONFIG, encoding="utf-8")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    repo = Path(__file__).resolve().parents[1]
    for args in (["episodes", str(root / "run"), "--config", str(cfg)],
                 ["export", str(root / "run"), "--format", "mjcf", "--out", str(root / "mjcf")]):
        proc = subprocess.run([sys.executable, "-m", "sdovon_mj.cli", *args], cwd=repo, env=env, capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return root
