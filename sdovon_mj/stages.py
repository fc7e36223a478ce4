"""The stage contract: every stage of the pipeline declared once.

A `Stage` names its scope (run, scene, variant, chain, export), the marker folder of its outputs in the run folder
(`key`), the stages whose outputs it reads (`needs`), the config it reads (`sections`: a section such as
``observe`` or one field such as ``world.floors``), further inputs of its fingerprint (`extra`: seeds, input
file digests, converter version), the stages that write its input files (`after`: run first, but only the
files' digests enter its fingerprint, so a converted scene depends on its content, not on who wrote it) and
the function that does the work (`make`, returning its output paths).
From that declaration alone come

- its fingerprint: ``fingerprint(name, needs' fingerprints, sections' values, extra)`` (`stage_fingerprint`);
- its run-folder paths (``key`` with ``{scene}``, ``{variant}``, ``{day}``, ``{fmt}`` filled in) and resume: a stage
  whose marker holds the same fingerprint (and whose outputs exist) is skipped (`run_stage`);
- the tasks of `sdovon_mj.pipeline` (a task runs the stages of one scope in declaration order) and the
  per-stage commands: ``sdovon-mj <stage> RUN_DIR`` runs that stage and the stages it needs through the
  same tasks as ``generate`` (`closure`), so both write the same bytes.

Scope ``chain`` is a scene's chain of days (``place.days``): one task per scene runs its stages day after day
(day t+1 reads day t), each day with its own markers, so a chain resumes at the first day not done.

Stage functions call each stage package's public API with records read through the run view; the stage
packages know records, config, store and sim, never this module. Seeds come from `sdovon_mj.seeds`.
"""

from __future__ import annotations

import shutil
import sys
from dataclasses import dataclass, field, is_dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Callable

from .config import RunConfig, to_dict
from .errors import InputError, InputsError, StageError
from .inputs import object_files, scene_problem
from .naming import name_scenes  # noqa: F401 (the run's scene names; re-exported)
from .plugins import converter
from .records import (DayChange, Instance, ReceptaclePlane, Relevance, SceneVariant, day_name, load_json, load_npz,
                      save_json, save_npz)
from .runview import RunLayout, RunView
from .seeds import day_seed, scene_seed, secret_salt, variant_seed
from .store import Store, file_hash, fingerprint

SCOPES = ("run", "scene", "variant", "chain", "export")


@dataclass
class StageContext:
    """What a stage function gets: the run folder, the config, and where in the run it works."""

    store: Store
    cfg: RunConfig
    scene: str = ""
    variant: int = -1
    fmt: str = ""
    notes: list[str] = field(default_factory=list)  # lines a stage logs; `run_stage` hands them to the task's result
    day: int = -1  # scope chain: the day of the scene's chain of days

    @property
    def view(self) -> RunView:
        """Return the read-only run view of the run folder."""
        return RunView(self.store.root)

    @property
    def scene_seed(self) -> int:
        """Return this scene's seed (`sdovon_mj.seeds`)."""
        return scene_seed(self.cfg.seed, self.scene)

    @property
    def variant_seed(self) -> int:
        """Return this variant's seed (`sdovon_mj.seeds`: the secret salt of a secret split mixed in)."""
        return variant_seed(self.scene_seed, self.variant, secret_salt())

    @property
    def variant_name(self) -> str:
        """Return this variant's name (`RunLayout.variant_name`)."""
        return RunLayout.variant_name(self.scene, self.variant)

    @property
    def day_seed(self) -> int:
        """Return this day's seed (`sdovon_mj.seeds`: the secret salt of a secret split mixed in)."""
        return day_seed(self.scene_seed, self.day, secret_salt())

    def key(self, stage: str, day: int | None = None) -> str:
        """Return the marker folder (store-relative) of a declared stage in this context (of another `day`)."""
        d = self.day if day is None else day
        return RunLayout.marker(stage, self.scene, self.variant_name, self.fmt, day_name(self.scene, d))

    @cached_property
    def inputs(self) -> dict[str, list[str]]:
        """Return the run's inputs.json ({'scenes': [...], 'objects': [...]}; empty lists: the default world)."""
        return self.store.read_json(RunLayout.INPUTS)

    def scene_source(self) -> str:
        """Return this scene's input file ('' for a default-world home)."""
        return scene_inputs(self.store, self.cfg)[self.scene]


@dataclass(frozen=True)
class Stage:
    """One declared stage. See the module docstring for what derives from the declaration."""

    name: str
    scope: str
    key: str
    needs: tuple[str, ...]
    sections: tuple[str, ...]
    outputs: str
    make: Callable[[StageContext], list[str]]
    extra: Callable[[StageContext], list[Any]] = field(default=lambda ctx: [])
    applies: Callable[[StageContext], bool] = field(default=lambda ctx: True)
    after: tuple[str, ...] = ()  # stages that write this one's input files (run first; their digests are in `extra`)
    when_sections: Callable[[RunConfig], tuple[str, ...]] = field(default=lambda cfg: ())
    drop: tuple[str, ...] = ()  # dotted fields of its sections it does not read (left out of its fingerprint)

    def read_sections(self, cfg: RunConfig) -> tuple[str, ...]:
        """Return every config section (or field) this stage reads under `cfg`."""
        return self.sections + tuple(self.when_sections(cfg))


def section_value(cfg: RunConfig, name: str) -> Any:
    """Return the plain value of a config section or dotted field (e.g. ``observe``, ``world.floors``)."""
    v: Any = cfg
    for part in name.split("."):
        v = getattr(v, part)
    return to_dict(v) if is_dataclass(v) else list(v) if isinstance(v, tuple) else v


def stage_fingerprint(stage: Stage, ctx: StageContext) -> str:
    """Return a stage's fingerprint: its name, what its needs recorded, the config it reads, its extra inputs."""
    needs = [_recorded_fp(ctx.store, ctx.key(n)) for n in stage.needs]
    conf = {s: section_value(ctx.cfg, s) for s in stage.read_sections(ctx.cfg)}
    for key in stage.drop:  # a field of a section read whole that this stage does not read
        sec, _, name = key.rpartition(".")
        if isinstance(conf.get(sec), dict):
            conf[sec].pop(name, None)
    return fingerprint(stage.name, needs, conf, *stage.extra(ctx))


def _recorded_fp(store: Store, key: str) -> str:
    """Return the fingerprint a finished stage recorded ('' when not finished)."""
    m = store.mark(key)
    return m.fingerprint if m else ""


def run_stage(name: str, ctx: StageContext, runner: Any) -> bool:
    """Run a declared stage in a context through `runner` (skipped when done with the same fingerprint).

    Returns whether it ran. A stage that does not apply in this context (e.g. the default-world writer for a
    scene given as a file) is passed over.
    """
    stage = STAGES[name]
    if not stage.applies(ctx):
        return False
    ran = runner.run(ctx.key(name), stage_fingerprint(stage, ctx), lambda: stage.make(ctx))
    if ctx.notes:  # the task's notes are printed by `generate` as the task ends
        result = getattr(runner, "result", None)
        if result is not None:
            result.notes.extend(f"{name}: {n}" for n in ctx.notes)
        else:
            print("\n".join(f"note: {name}: {n}" for n in ctx.notes), file=sys.stderr)
        ctx.notes.clear()
    return ran


def closure(names: list[str] | tuple[str, ...]) -> list[str]:
    """Return the named stages and every stage they need, in declaration order."""
    want: set[str] = set()
    todo = list(names)
    while todo:
        n = todo.pop()
        if n not in STAGES:
            raise StageError(f"unknown stage '{n}' (stages: {', '.join(STAGES)})")
        if n not in want:
            want.add(n)
            todo += STAGES[n].needs + STAGES[n].after
    return [n for n in STAGES if n in want]


def scope_stages(scope: str, selected: list[str] | tuple[str, ...] | None = None) -> list[str]:
    """Return the stages of a scope in declaration order (only those in `selected`, when given)."""
    return [n for n, s in STAGES.items() if s.scope == scope and (selected is None or n in selected)]


# ----------------------------------------------------------------------------------------------
# Inputs: scene names and object files


def scene_inputs(store: Store, cfg: RunConfig) -> dict[str, str]:
    """Return scene name -> input file ('' for a default-world home)."""
    return scene_table(store.read_json(RunLayout.INPUTS)["scenes"], cfg)


def scene_table(scenes: list[str] | None, cfg: RunConfig) -> dict[str, str]:
    """Return scene name -> input of a run with these (expanded) scene inputs; none: the default world's homes
    (name -> '')."""
    if not scenes:
        from .world.presets import preset

        return {f"{preset(cfg.world.preset).scene}_{seed:04d}": "" for seed in cfg.world.scene_seeds}
    return name_scenes([str(s) for s in scenes])


def select_scenes(names: list[str], patterns: list[str] | None) -> list[str]:
    """Return the names matching any of the patterns (shell globs: ``apt_*``, ``1023[0-4]*``), in run order; raise
    InputError (exit 2) naming a pattern that matches no scene. No patterns: every name."""
    import fnmatch

    if not patterns:
        return list(names)
    unmatched = [pat for pat in patterns if not fnmatch.filter(names, pat)]
    if unmatched:
        shown = ", ".join(names[:20]) + (f" ... ({len(names)} in all)" if len(names) > 20 else "")
        raise InputError("--scene", f"{', '.join(repr(u) for u in unmatched)} matches no scene of the run "
                                    f"(scenes: {shown or 'none'})")
    return [n for n in names if any(fnmatch.fnmatchcase(n, pat) for pat in patterns)]


def expand_scene_inputs(scenes: list[str] | None, cfg: RunConfig | None = None) -> list[str] | None:
    """Return the scene inputs with each input replaced by the scenes it stands for (the converter plugin's
    ``scene_files``): a Habitat scene dataset config, each of its scenes; a folder of scenes, each scene in it; a
    ``sdovon-mj convert`` output or run folder, each converted scene's folder; a converted scene's folder, itself.
    Raise InputError for a folder that holds no scene. Each scene once, in input order.
    """
    if not scenes:
        return scenes
    conv = converter()
    out: list[str] = []
    for s in scenes:
        p = Path(s)
        if not p.exists() or not hasattr(conv, "scene_files"):
            out.append(s)  # the input check names a missing file
            continue
        try:
            found = [str(f) for f in conv.scene_files(p)]
        except InputError as e:  # an unreadable dataset config: a usage error, named before any work
            raise InputsError([(f"scene {s}" + ("" if e.path == str(p) else f" ({e.path})"), e.cause)]) from None
        if not found and p.is_dir():
            raise InputsError([(f"scene folder {s}", "holds no scene (no converted scene, no scene file, no scene "
                                                      "dataset config)")])
        out.extend(found or [s])
    seen: set[str] = set()
    return [x for x in out if not (x in seen or seen.add(x))]  # type: ignore[func-returns-value]


def scene_names(store: Store, cfg: RunConfig) -> list[str]:
    """Return the run's scene names in a fixed order."""
    return list(scene_inputs(store, cfg))


def _meta_category(path: Path) -> str | None:
    """Return the category named by a meta.json beside an object file, if any."""
    import json

    meta = path.parent / "meta.json"
    if meta.exists():
        try:
            return str(json.loads(meta.read_text(encoding="utf-8"))["category"])
        except (json.JSONDecodeError, KeyError):
            return None
    return None


def _object_files(ctx: StageContext) -> list[tuple[Path, str | None]]:
    """Return (object file, category or None) for every input object (the default library once written)."""
    if ctx.inputs["objects"]:
        files: list[tuple[Path, str | None]] = []
        # the converter's category (as `convert` gives it: assets.yaml, else meta.json, else its guess, which knows the
        # library folder: a flat lib/mug.obj is a mug, not a 'lib'); a converter without one: meta.json only
        guess = getattr(converter(), "object_category", None)
        for p in map(Path, ctx.inputs["objects"]):  # the input check's files (it names a missing or bad one)
            folder = p if p.is_dir() else None
            files += [(q, guess(q, folder) if guess else _meta_category(q)) for q in object_files(p)]
        return files
    mark = ctx.store.mark(ctx.key("world:objects"))
    if mark is None:
        raise StageError("the default object library was not written (stage world:objects)")
    return [(ctx.store.path(o), _meta_category(ctx.store.path(o))) for o in mark.outputs
            if o.endswith((".obj", ".glb", ".ply"))]


def _input_name(store: Store, path: Path) -> str:
    """Return an input file's name for fingerprints: store-relative inside the run folder, else absolute."""
    try:
        return store.rel(path)
    except ValueError:
        return str(Path(path).resolve())


# ----------------------------------------------------------------------------------------------
# Stage functions (each calls one stage package's public API)


def _world_objects(ctx: StageContext) -> list[str]:
    """Write the default world's object library as input files."""
    from .world import write_object_library

    w = ctx.cfg.world
    paths = write_object_library(w.object_seed, ctx.store.path(ctx.key("world:objects")), variants=w.object_variants,
                                 categories=list(w.object_categories) or None)
    return [ctx.store.rel(p) for p in paths]


def _objects(ctx: StageContext) -> list[str]:
    """Convert the object library into ``objects/<name>/`` (+ object.json) and ``objects/objects.json``."""
    conv = converter()
    assets, failures = conv.convert_library(_object_files(ctx), ctx.store.root, ctx.cfg.convert)
    failures.update({k: v for k, v in _library_skipped(ctx, conv).items() if k not in failures})
    if not assets:
        raise StageError("no object converted: " + "; ".join(f"{k}: {v}" for k, v in failures.items()))
    save_json(assets, ctx.store.path(RunLayout.OBJECT_LIBRARY))
    ctx.store.write_json(RunLayout.OBJECT_FAILURES, failures)
    return [RunLayout.OBJECT_LIBRARY, RunLayout.OBJECT_FAILURES] + [RunLayout.object_record(a.name) for a in assets]


def _library_skipped(ctx: StageContext, conv: Any) -> dict[str, str]:
    """Return {file: why} for the files of formats the converter does not read in the input object folders."""
    out: dict[str, str] = {}
    if hasattr(conv, "skipped_files"):
        for p in map(Path, ctx.inputs["objects"] or []):
            if p.is_dir():
                out.update(conv.skipped_files(p, "object"))
    return out


def _objects_extra(ctx: StageContext) -> list[Any]:
    """Return the object stage's further inputs: converter version, (name, category, digest) per file, and the
    files it skips (listed in failures.json: a .dae added to a finished run's library folder is listed on resume)."""
    conv = converter()
    extra = [conv.version, [(_input_name(ctx.store, p), c, file_hash(p), *_further_inputs(conv, p))
                            for p, c in _object_files(ctx)]]
    skipped = sorted(_library_skipped(ctx, conv))
    return extra + [skipped] if skipped else extra  # none: the fingerprint of runs before it


def _convert_extra(conv: Any, path: Path) -> list[Any]:
    """Return the convert stage's further inputs: converter version, the scene file's digest, its companions'
    (a converted scene's folder: the digests of the files the converter names for it)."""
    return [conv.version, file_hash(path) if path.is_file() else "folder", *_further_inputs(conv, path)]


def _further_inputs(conv: Any, path: Path) -> list[Any]:
    """Return what a fingerprint holds of `path` beyond its own digest, each part only when not empty (so a fingerprint
    keeps its bytes): [digest of each further file the converter reads for it] (metadata, companions), then the
    conversion rules the converter names for it and those files (GPU textures' orientation: a rule that changed how
    such inputs convert redoes their conversion on resume). The further files are listed once for both."""
    extra = getattr(conv, "extra_inputs", None)
    files = list(extra(path)) if extra is not None else []
    params = getattr(conv, "key_params", None)
    rules = params(path, files) if params is not None else {}
    return ([[file_hash(Path(f)) for f in files]] if files else []) + ([rules] if rules else [])


def _world_scene(ctx: StageContext) -> list[str]:
    """Write a default-world home (the ``world.preset``'s) as an input file."""
    from .world import generate_home, write_apartment

    w = ctx.cfg.world
    rel_dir = ctx.key("world:scene")
    apt = generate_home(_apartment_seed(ctx.scene), w.preset, floors=w.floors or None, articulated=w.articulated)
    mesh = write_apartment(apt, ctx.store.path(rel_dir), mode=w.scene_mode, name=ctx.scene)
    return sorted(ctx.store.rel(p) for p in ctx.store.path(rel_dir).rglob("*")
                  if p.is_file() and not p.name.startswith(".")) or [ctx.store.rel(mesh)]


def _apartment_seed(scene: str) -> int:
    """Return the home seed of a default-world scene name (``apt_<seed>``, ``house_<seed>``)."""
    return int(scene.split("_")[-1])


def scene_file(ctx: StageContext) -> Path:
    """Return the input file of this context's scene (the written apartment for a default-world scene)."""
    src = ctx.scene_source()
    if not src:
        mark = ctx.store.mark(ctx.key("world:scene"))
        mesh = [o for o in (mark.outputs if mark else []) if o.endswith((".glb", ".ply")) and not o.endswith(".segs.json")]
        if not mesh:
            raise StageError(f"default-world apartment {ctx.scene} wrote no mesh")
        src = str(ctx.store.path(mesh[0]))
    path = Path(src)
    why = scene_problem(path)  # the input check, again: a resumed run's input may have changed since
    if why:
        raise InputError(path, why)
    return path


def _convert(ctx: StageContext) -> list[str]:
    """Convert the scene file into ``scenes/<scene>/`` (scene.json, MJCF, mesh sidecar)."""
    asset = converter().convert_scene(scene_file(ctx), ctx.store.root, ctx.scene, ctx.cfg.convert)
    save_json(asset, ctx.store.path(RunLayout.scene_record(ctx.scene)))
    return [RunLayout.scene_record(ctx.scene), asset.mjcf, asset.mesh]


def _observe(ctx: StageContext) -> list[str]:
    """Floors, navigable maps, coverage view points and RGB-D(+seg) shards of the scene."""
    from .observe import observe_scene

    summary = observe_scene(ctx.view.scene(ctx.scene), ctx.store.root, ctx.key("observe"), ctx.cfg.observe,
                            seed=ctx.scene_seed, agent=ctx.cfg.agent)
    ctx.notes.extend(summary["log"])
    return list(summary["outputs"])


# The semantics fields that decide what the LLM backend answers (perceive asks it to name receptacles):
# the window and region-map fields do not, so changing them does not redo perception.
LLM_IDENTITY = tuple(f"semantics.{f}" for f in ("backend", "model", "url", "retries", "fallback", "offline_model",
                                               "temperature", "seed"))


def _offline_semantics() -> str:
    """Return the digest of the offline backend's shipped model and priors (the semantics stage's extra input)."""
    from .semantics import offline_data_digest

    return offline_data_digest()


def _llm_backend(ctx: StageContext) -> Any:
    """Return the run's LLM backend (replies cached under cache/llm of the run folder when enabled)."""
    from .semantics import get_backend

    cfg = ctx.cfg
    return get_backend(cfg.semantics, cache_dir=ctx.store.path(RunLayout.LLM_CACHE) if cfg.semantics.cache else None)


def _perceive(ctx: StageContext) -> list[str]:
    """Fused instances, receptacle planes and targeted views of the scene."""
    from .observe import load_shards
    from .perceive.surfaces import perceive_and_find_planes, save_targeted_views

    shards = sorted(ctx.store.root.glob(RunLayout.observations(ctx.scene)))
    # with no prespecified receptacle labels the LLM backend names them (prompt C.1), cached like semantics
    backend = None if ctx.cfg.receptacles.labels and not ctx.cfg.receptacles.llm_share else _llm_backend(ctx)
    instances, planes, views = perceive_and_find_planes(load_shards(shards), ctx.view.scene(ctx.scene), ctx.store.root,
                                                        ctx.view.navmaps(ctx.scene), ctx.cfg, ctx.scene_seed, backend)
    if ctx.view.scene(ctx.scene).articulated:  # planes inside articulated pieces name the part that closes them
        from .receptacles.inside import assign_parts

        planes = assign_parts(planes, ctx.view.scene(ctx.scene), ctx.store.root, ctx.cfg.observe.open_parts, instances)
    out = [RunLayout.instances(ctx.scene), RunLayout.planes(ctx.scene, "perceive"), RunLayout.targeted_views(ctx.scene),
           RunLayout.llm_record(ctx.scene)]
    save_npz(instances, ctx.store.path(out[0]))
    save_json(planes, ctx.store.path(out[1]))
    save_targeted_views(views, ctx.store.path(out[2]))
    # receptacle naming's LLM replies that failed and fell back (semantics records its own in its records)
    ctx.store.write_json(out[3], {"backend": backend.label if backend is not None else "",
                                           "fallbacks": list(backend.fallbacks) if backend is not None else []})
    return out


def _semantics(ctx: StageContext) -> list[str]:
    """Region maps per floor, planes with floor and region, relevance of the library's categories."""
    from .semantics import annotate_planes, input_region_map, region_map, region_picture, relevance

    sc = ctx.scene
    instances: list[Instance] = load_npz(ctx.store.path(RunLayout.instances(sc)))  # type: ignore[assignment]
    planes: list[ReceptaclePlane] = load_json(ctx.store.path(RunLayout.planes(sc, "perceive")), ReceptaclePlane)
    backend = _llm_backend(ctx)
    outs: list[str] = []
    maps = {}
    rooms = ctx.view.scene(ctx.scene).rooms if ctx.cfg.semantics.regions == "input" else None
    for nm in ctx.view.navmaps(ctx.scene):
        if rooms is not None:
            try:
                rm = input_region_map(rooms, nm)
            except ValueError as e:
                raise StageError(str(e)) from None
        else:
            rm = region_map(instances, nm, backend, ctx.cfg.semantics)
        maps[nm.floor] = (nm, rm)
        rec, pic = RunLayout.regions(sc, nm.floor), RunLayout.regions(sc, nm.floor, ".png")
        save_json(rm, ctx.store.path(rec))
        region_picture(rm, ctx.store.path(pic), navmap=nm)
        outs += [rec, pic]
    annotated = annotate_planes(planes, maps)
    save_json(annotated, ctx.store.path(RunLayout.planes(sc, "semantics")))
    categories = sorted({o.category for o in ctx.view.object_library()})
    regions = sorted({p.region for p in annotated if p.region} | set(ctx.cfg.semantics.region_labels))
    receptacles = sorted({p.label for p in annotated})
    save_json(relevance(categories, regions, receptacles, backend), ctx.store.path(RunLayout.relevance(sc)))
    return outs + [RunLayout.planes(sc, "semantics"), RunLayout.relevance(sc)]


def _place(ctx: StageContext) -> list[str]:
    """Sample, settle and write one variant of the scene."""
    from .place import place_variant

    planes = load_json(ctx.store.path(RunLayout.planes(ctx.scene, "semantics")), ReceptaclePlane)
    rel = load_json(ctx.store.path(RunLayout.relevance(ctx.scene)), Relevance)
    variant = place_variant(ctx.view.scene(ctx.scene), planes, rel, ctx.view.object_library(), ctx.store.root,
                            ctx.cfg.place, ctx.variant_seed, ctx.variant, open_parts=ctx.cfg.observe.open_parts)
    return [RunLayout.variant_record(ctx.scene, ctx.variant_name), variant.mjcf]


def _episodes(ctx: StageContext) -> list[str]:
    """ObjectNav episodes of one variant."""
    from .episodes import generate_episodes

    variant = load_json(ctx.store.path(RunLayout.variant_record(ctx.scene, ctx.variant_name)), SceneVariant)
    eps = generate_episodes(variant, ctx.view.navmaps(ctx.scene), ctx.store.root, ctx.cfg.episodes, ctx.variant_seed,
                            agent=ctx.cfg.agent)
    path = RunLayout.episodes(ctx.scene, ctx.variant_name)
    save_json(eps, ctx.store.path(path))
    return [path]


def _day(ctx: StageContext) -> list[str]:
    """Place one day of the scene's chain: day 0 as a variant, a later day from the day before by the habit model."""
    from .place.days import first_day, next_day

    planes = load_json(ctx.store.path(RunLayout.planes(ctx.scene, "semantics")), ReceptaclePlane)
    rel = load_json(ctx.store.path(RunLayout.relevance(ctx.scene)), Relevance)
    name = day_name(ctx.scene, ctx.day)
    args = (ctx.view.scene(ctx.scene), planes, rel, ctx.view.object_library(), ctx.store.root, ctx.cfg.place,
            ctx.day_seed)
    if ctx.day == 0:
        variant, _change = first_day(*args, open_parts=ctx.cfg.observe.open_parts)
    else:
        before = day_name(ctx.scene, ctx.day - 1)
        previous = load_json(ctx.store.path(RunLayout.day_record(ctx.scene, before)), SceneVariant)
        change = load_json(ctx.store.path(RunLayout.day_change(ctx.scene, before)), DayChange)
        variant, _change = next_day(previous, change, *args)
    return [RunLayout.day_record(ctx.scene, name), RunLayout.day_change(ctx.scene, name), variant.mjcf]


def _day_episodes(ctx: StageContext) -> list[str]:
    """ObjectNav episodes of one day of the chain, each goal labelled by its history since the day before."""
    from .episodes import generate_episodes, label_day

    name = day_name(ctx.scene, ctx.day)
    variant = load_json(ctx.store.path(RunLayout.day_record(ctx.scene, name)), SceneVariant)
    change = load_json(ctx.store.path(RunLayout.day_change(ctx.scene, name)), DayChange)
    eps = generate_episodes(variant, ctx.view.navmaps(ctx.scene), ctx.store.root, ctx.cfg.episodes, ctx.day_seed,
                            agent=ctx.cfg.agent)
    save_json(label_day(eps, change), ctx.store.path(RunLayout.day_episodes(ctx.scene, name)))
    return [RunLayout.day_episodes(ctx.scene, name)]


def _day_extra(ctx: StageContext) -> list[Any]:
    """Return a day's further fingerprint inputs: its seed and what the day before recorded (day t+1 needs day t)."""
    return [ctx.day_seed, ctx.day, _recorded_fp(ctx.store, ctx.key("day", ctx.day - 1)) if ctx.day > 0 else ""]


def export_unit_key(fmt: str, unit: str) -> str:
    """Return the marker folder (store-relative) of one export unit (`RunLayout.export_unit`)."""
    return RunLayout.export_unit(fmt, unit)


def _export_setup(ctx: StageContext) -> tuple[Any, Any, list[Any] | None]:
    """Return (exporter, options, its units or None) of this context's format."""
    from .export import ExportOptions, exporter_units, make_exporter

    exporter = make_exporter(ctx.fmt)
    options = ExportOptions(name=ctx.cfg.name, split=ctx.cfg.split, secret=ctx.view.secret_split())
    return exporter, options, exporter_units(exporter, ctx.view, options)


def _exporter_version(fmt: str) -> str:
    """Return an exporter plugin's layout version ('' when it declares none or cannot be loaded here)."""
    from .export import make_exporter

    try:
        return str(getattr(make_exporter(fmt), "version", "") or "")
    except Exception:  # the export task itself reports why the plugin does not load
        return ""


def _unit_fingerprint(ctx: StageContext, unit: Any, options: Any) -> str:
    """Return an export unit's fingerprint: format, unit, the export stage's config, the records the unit reads."""
    from .export import unit_digest

    conf = {s: section_value(ctx.cfg, s) for s in STAGES["export"].read_sections(ctx.cfg)}
    return fingerprint("export:unit", ctx.fmt, _exporter_version(ctx.fmt), unit.key, list(unit.scenes) if unit.scenes is not None else None,
                       conf, options.extra, unit_digest(ctx.view, unit))


def run_export_units(ctx: StageContext, runner: Any, only: str = "") -> bool:
    """Run the units of this context's exporter through `runner` (each skipped when done); only `only` if given.

    Without `only` (the finishing step's task) a unit whose marker holds its fingerprint and whose outputs
    exist is passed over without a note: its own task verified it.

    Returns False when the exporter declares no units (it runs as one task in the export stage).
    """
    exporter, options, units = _export_setup(ctx)
    if units is None:
        return False
    if only and only not in {u.key for u in units}:
        raise StageError(f"exporter {ctx.fmt} has no unit '{only}' (units: {', '.join(u.key for u in units)})")
    out = ctx.store.path(RunLayout.export_dir(ctx.fmt))
    for unit in units:
        if only and unit.key != only:
            continue
        key = export_unit_key(ctx.fmt, unit.key)
        fp = _unit_fingerprint(ctx, unit, options)
        if not only and ctx.store.is_done(key, fp):  # the finishing step: a unit its own task finished
            continue

        def make(unit: Any = unit, key: str = key) -> list[str]:
            res = exporter.export_unit(ctx.view, out, options, unit)
            ctx.store.write_json(f"{key}/unit.json", res.to_dict())
            return [f"{key}/unit.json"] + [f"{RunLayout.export_dir(ctx.fmt)}/{f}" for f in res.files]

        runner.run(key, fp, make)
    return True


def _export(ctx: StageContext) -> list[str]:
    """Run one exporter plugin into ``export/<fmt>/`` (our own folder: nothing else is kept there).

    An exporter with units: its units ran before (`run_export_units`, each with its own marker); this step
    writes the dataset-level files (`Exporter.finish`), records the export and removes files no unit wrote.
    Without units: the folder is replaced whole by one `Exporter.export`.
    """
    from .export import UnitResult, record_export, run_export

    exporter, options, units = _export_setup(ctx)
    out = ctx.store.path(RunLayout.export_dir(ctx.fmt))
    if units is None:
        if out.exists():
            shutil.rmtree(out)
        report = run_export(exporter, ctx.view, out, options)
        own = report.files
    else:
        results = []
        for u in units:
            key = export_unit_key(ctx.fmt, u.key)
            if not ctx.store.exists(f"{key}/unit.json"):
                raise StageError(f"export {ctx.fmt}: unit {u.key} has not finished ({key})")
            results.append(UnitResult.from_dict(ctx.store.read_json(f"{key}/unit.json")))
        out.mkdir(parents=True, exist_ok=True)
        report = exporter.finish(ctx.view, out, options, results)
        record_export(out, ctx.fmt, options.name, options.split, ctx.view.run_id())
        by_units = {f for r in results for f in r.files}
        own = [f for f in report.files if f not in by_units]
        keep = set(report.files) | {"sdovon_export.json"}
        for p in sorted(out.rglob("*"), reverse=True):  # files of an earlier export that no unit wrote now
            rel = p.relative_to(out).as_posix()
            if p.is_file() and rel not in keep:
                p.unlink()
            elif p.is_dir() and not any(p.iterdir()):
                p.rmdir()
        udir = ctx.store.path(RunLayout.export_unit(ctx.fmt))
        for d in sorted(udir.iterdir()) if udir.is_dir() else []:
            if d.is_dir() and d.name not in {u.key for u in units}:
                shutil.rmtree(d)
    ctx.store.write_json(RunLayout.export_report(ctx.fmt), {"format": report.format, "variants": report.variants,
                                                           "skipped": report.skipped, "episodes": report.episodes})
    return [RunLayout.export_report(ctx.fmt)] + [f"{RunLayout.export_dir(ctx.fmt)}/{f}" for f in own]


# ----------------------------------------------------------------------------------------------
# The declarations (order = the order stages run in within a task)

# The habit model's keys (place.day_*) are read by the chains of days only; how many days a chain has is read by
# none of its days (day t is the same in a chain of 3 days and of 5), so a longer chain keeps the days it had.
DAY_KEYS = ("place.day_move", "place.day_leave", "place.day_arrive", "place.day_rates")

_DECLARED = [
    Stage("world:objects", "run", RunLayout.MARKERS["world:objects"], (), ("world.object_seed", "world.object_variants", "world.object_categories"),
          "the default world's object library as input files (only when no --objects are given)",
          _world_objects, applies=lambda ctx: not ctx.inputs["objects"]),
    Stage("objects", "run", RunLayout.MARKERS["objects"], (), ("convert",),
          "objects/objects.json (list[ObjectAsset]), objects/failures.json, objects/<name>/ (MJCF, hulls, textures)",
          _objects, extra=_objects_extra, after=("world:objects",)),
    Stage("world:scene", "scene", RunLayout.MARKERS["world:scene"], (), ("world.floors", "world.scene_mode"),
          "a default-world apartment as an input file (only for default-world scenes)",
          _world_scene, extra=lambda ctx: [_apartment_seed(ctx.scene)] + (["articulated"] if ctx.cfg.world.articulated else [])
          + ([ctx.cfg.world.preset] if ctx.cfg.world.preset != "apartment" else []), applies=lambda ctx: not ctx.scene_source()),
    Stage("convert", "scene", RunLayout.MARKERS["convert"], (), ("convert",),
          "scenes/<scene>/scene.json (SceneAsset), its MJCF and mesh sidecar",
          _convert, extra=lambda ctx: _convert_extra(converter(), scene_file(ctx)),
          after=("world:scene",)),
    Stage("observe", "scene", RunLayout.MARKERS["observe"], ("convert",),
          ("observe", "agent.radius", "agent.height", "agent.camera_height", "agent.hfov"),
          "navmap_<floor>.json, viewpoints.json, obs_*.npz shards, pictures",
          _observe, extra=lambda ctx: [ctx.scene_seed]),
    Stage("perceive", "scene", RunLayout.MARKERS["perceive"], ("observe",),
          ("observe", "perceive", "receptacles", "agent.camera_height", "agent.hfov", "agent.eta_gt"),
          "instances.npz, planes.json, targeted_views.json, llm.json (receptacle naming: backend, fallbacks)",
          _perceive, extra=lambda ctx: [ctx.scene_seed],
          when_sections=lambda cfg: () if cfg.receptacles.labels and not cfg.receptacles.llm_share else LLM_IDENTITY),
    Stage("semantics", "scene", RunLayout.MARKERS["semantics"], ("perceive", "objects"), ("semantics",),
          "regions_<floor>.json + .png, planes.json (with floor and region), relevance.json",
          _semantics, extra=lambda ctx: [_offline_semantics()]),
    Stage("place", "variant", RunLayout.MARKERS["place"], ("semantics", "objects"), ("place",),
          "variant.json (SceneVariant) and the composed variant MJCF",
          _place, extra=lambda ctx: [ctx.variant_seed],
          when_sections=lambda cfg: ("observe.open_parts",) if cfg.world.articulated else (),
          drop=("place.days",) + DAY_KEYS),
    Stage("episodes", "variant", RunLayout.MARKERS["episodes"], ("place",),
          ("episodes", "agent.camera_height", "agent.hfov", "agent.eta_gt"),
          "episodes.json (list[Episode])",
          _episodes, extra=lambda ctx: [ctx.variant_seed]),
    Stage("day", "chain", RunLayout.MARKERS["day"], ("semantics", "objects"), ("place",),
          "variant.json (SceneVariant with its day), day.json (DayChange: stayed, moved, left, arrived) and the "
          "composed MJCF of one day of the scene's chain (place.days)",
          _day, extra=_day_extra, applies=lambda ctx: ctx.cfg.place.days > 0,
          when_sections=lambda cfg: ("observe.open_parts",) if cfg.world.articulated else (), drop=("place.days",)),
    Stage("day:episodes", "chain", RunLayout.MARKERS["day:episodes"], ("day",),
          ("episodes", "agent.camera_height", "agent.hfov", "agent.eta_gt"),
          "episodes.json (list[Episode] with the day, each goal's history)",
          _day_episodes, extra=lambda ctx: [ctx.day_seed], applies=lambda ctx: ctx.cfg.place.days > 0),
    Stage("export", "export", RunLayout.MARKERS["export"], (), ("name", "split", "episodes"),
          "export/<fmt>/ (the exporter plugin's files), export/<fmt>.report.json",
          _export, extra=lambda ctx: [ctx.fmt, _exporter_version(ctx.fmt), ctx.view.run_id()]),
]
STAGES: dict[str, Stage] = {s.name: s for s in _DECLARED}
# the commands `sdovon-mj <stage>` (world writers, conversion and export have their own: world, convert, export)
COMMAND_STAGES = ("observe", "perceive", "semantics", "place", "episodes")


def describe() -> str:
    """Return a table of the declared stages (name, scope, needs, config read, outputs)."""
    rows = [f"{'stage':<14}{'scope':<9}{'needs':<22}{'config':<38}outputs"]
    for s in STAGES.values():
        rows.append(f"{s.name:<14}{s.scope:<9}{','.join(s.needs) or '-':<22}{','.join(s.sections) or '-':<38}{s.outputs}")
    return "\n".join(rows)


def run_task(store: Store, cfg: RunConfig, runner: Any, scope: str, scene: str = "", variant: int = -1, fmt: str = "",
             selected: list[str] | tuple[str, ...] | None = None, fits: Callable[[], bool] | None = None) -> list[str]:
    """Run the (selected) stages of one scope in declaration order, in one context; return the stages left.

    Parameters
    ----------
    store : Store
        The run folder.
    cfg : RunConfig
        The run's config.
    runner : StageRunner
        Runs a stage once per fingerprint and records seconds (`sdovon_mj.tasks.StageRunner`).
    scope : str
        ``run``, ``scene``, ``variant``, ``chain`` (a scene's days, in order) or ``export``.
    scene, variant, fmt : str, int, str
        Where in the run: the scene name, the variant index, the export format (scope ``export``: ``scene``
        names one export unit to run alone; empty: every unit not done yet, then the finishing step).
    selected : sequence of str, optional
        Only these stages (default: every stage of the scope).
    fits : callable, optional
        Asked before each stage after one that ran: False stops here, and the stages not run are returned (the
        caller runs them in a fresh process; `sdovon_mj.tasks.run_task`). Default: run them all.
    """
    if scope not in SCOPES:
        raise StageError(f"unknown stage scope '{scope}' ({', '.join(SCOPES)})")
    if scope == "chain":  # day after day; a day done (its markers) is skipped, so a fresh process resumes the chain
        names = scope_stages(scope, selected)
        ran = False
        for day in range(cfg.place.days):
            ctx = StageContext(store, cfg, scene, day=day)
            for name in names:
                if ran and fits is not None and not fits():
                    return names
                ran = run_stage(name, ctx, runner) or ran
        return []
    ctx = StageContext(store, cfg, scene, variant, fmt)
    if scope == "export" and "export" in scope_stages(scope, selected):
        # An exporter's units first (each skipped when done); a task naming one unit (`scene`) runs only it.
        if run_export_units(ctx, runner, only=scene) and scene:
            return []
    names = scope_stages(scope, selected)
    ran = False
    for i, name in enumerate(names):
        if ran and fits is not None and not fits():
            return names[i:]
        ran = run_stage(name, ctx, runner) or ran
    return []


__all__ = ["COMMAND_STAGES", "STAGES", "SCOPES", "Stage", "StageContext", "closure", "converter", "describe", "run_stage",
           "export_unit_key", "run_export_units",
           "expand_scene_inputs", "name_scenes", "run_task", "scene_inputs", "scene_names", "scene_table", "select_scenes", "scope_stages", "section_value", "stage_fingerprint"]
