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


# Session fixtures that generate a run, and the test modules that read each: under pytest-xdist a shared run's
# modules run on one worker, so the run is generated once (checked at collection: a module reading one of them
# must be listed here).
SHARED_RUNS = {"tiny_export_run": ("test_export_usd.py", "test_export_urdf.py", "test_export_genesis.py",
                                   "test_eval_secret_split.py"),
               "articulated_closed_run": ("test_articulated_pipeline.py", "test_articulated_suite.py", "test_viewer.py")}
SLOW_COST = 30  # a slow-marked test counts as this many fast ones when groups are ordered (slow: more than ~20 s)


def work_group(nodeid: str) -> str:
    """Return the group a test runs in under pytest-xdist: its module, or the shared run its module reads."""
    path = nodeid.split("::", 1)[0]
    return next((run for run, mods in SHARED_RUNS.items() if Path(path).name in mods), path)


@pytest.hookimpl(tryfirst=True, optionalhook=True)  # optional: a plain pytest without xdist has no such hook
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """With ``--dist loadscope`` (``./run.sh test``): one work unit per `work_group`, handed out in collection order.

    A module's tests stay on one worker (its module fixtures are built once), and so do the modules of a shared run.
    (xdist's ``loadgroup`` would do this through marks, but it renames node ids in a way pytest 9 ignores.)
    """
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_group(nodeid)

    config.option.loadscopereorder = False  # the collection order is the cost order (pytest_collection_modifyitems)
    return GroupScheduling(config, log)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under pytest-xdist: check that every module reading a shared run is listed in `SHARED_RUNS`, and send the
    costliest groups first (xdist hands groups out in collection order; a long test taken last would run alone at
    the end). Cost: one per test, `SLOW_COST` per slow-marked test. Without xdist, nothing changes.
    """
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    group = {item.nodeid: work_group(item.nodeid) for item in items}
    cost: dict[str, int] = {}
    for item in items:
        for run in SHARED_RUNS:
            if run in item.fixturenames and group[item.nodeid] != run:
                raise pytest.UsageError(f"{item.nodeid} reads the shared run {run}: add its module to SHARED_RUNS "
                                        "in tests/conftest.py")
        g = group[item.nodeid]
        cost[g] = cost.get(g, 0) + (SLOW_COST if item.get_closest_marker("slow") else 1)
    first = {g: k for k, g in enumerate(dict.fromkeys(group.values()))}
    items.sort(key=lambda i: (-cost[group[i.nodeid]], first[group[i.nodeid]]))  # stable: order within a group kept


@pytest.fixture(autouse=True, scope="module")
def _memory_back_after_each_module(request: pytest.FixtureRequest) -> Generator[None, None, None]:
    """After a module: empty its functools caches (observations, worlds) and give freed heap back to the system.

    Why: a pytest process runs hundreds of tests, and with two workers (``./run.sh test``) two of them hold what
    their modules left behind at the same time, on a CI machine whose memory we do not choose.
    """
    yield
    from sdovon_mj.memory import release_memory

    for obj in list(vars(request.module).values()):
        if callable(getattr(obj, "cache_clear", None)) and getattr(obj, "__module__", None) == request.module.__name__:
            obj.cache_clear()
    release_memory()


@pytest.fixture(autouse=True, scope="module")
def _subnormals_kept(request: pytest.FixtureRequest) -> Generator[None, None, None]:
    """Fail a module that leaves flush-to-zero / denormals-are-zero on in the test process (``genesis.init`` does):
    it would change the arithmetic of every later test in the same process, byte comparisons included."""
    yield
    tiny = float.fromhex("0x1p-1074")  # the smallest subnormal double
    if not tiny * 1.0 > 0.0:
        pytest.fail(f"{request.module.__name__} left flush-to-zero / denormals-are-zero on in the test process: run "
                    "what sets it (Genesis' init, a library built with -ffast-math) in a subprocess")


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
