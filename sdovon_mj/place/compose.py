"""Compose one MuJoCo model per variant with MjSpec: the converted scene (visual only, optional), the
support geoms (group 4) and each object model attached as body ``obj_<n>`` with a freejoint.

Object models are the converter's Menagerie-style ``model.xml`` (classes visual/collision, no
freejoint). Asset file paths are made absolute while composing and written back relative to the
composed file, so it loads from any working directory and moves together with its store.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from ..config import PlaceConfig
from ..errors import InputError
from ..records import ObjectAsset, Placement, ReceptaclePlane, SceneAsset
from ..sim import GROUP_OBJECT_COLLISION
from .support import SupportInfo, add_support

_SPEC_CACHE: dict[tuple[str, bool, float], mujoco.MjSpec] = {}
_SCENE_CACHE: dict[tuple[str, str, float], mujoco.MjSpec] = {}
_FILE_ATTR = re.compile(r'(\sfile=")([^"]*)(")')


@dataclass
class Composed:
    """A compiled model with where its objects' free joints and bodies are."""

    spec: mujoco.MjSpec
    model: mujoco.MjModel
    support: SupportInfo
    object_ids: list[str]
    qpos_adr: list[int]
    qvel_adr: list[int]
    body_ids: list[int]


def _absolutise(spec: mujoco.MjSpec, model_dir: Path) -> None:
    """Rewrite a spec's mesh/texture/hfield/skin file paths as absolute paths."""
    meshdir = spec.meshdir or ""
    texdir = spec.texturedir or ""
    for m in spec.meshes:
        if m.file:
            m.file = str((model_dir / meshdir / m.file).resolve())
    for t in spec.textures:
        if t.file:
            t.file = str((model_dir / texdir / t.file).resolve())
        if hasattr(t, "cubefiles"):
            t.cubefiles = [str((model_dir / texdir / f).resolve()) if f else f for f in t.cubefiles]
    for h in spec.hfields:
        if h.file:
            h.file = str((model_dir / h.file).resolve())
    for s in spec.skins:
        if s.file:
            s.file = str((model_dir / meshdir / s.file).resolve())
    spec.meshdir = ""
    spec.texturedir = ""


def load_object_spec(asset: ObjectAsset, store_root: str | Path, visual: bool = True) -> mujoco.MjSpec:
    """Return a fresh spec of an object model (absolute asset paths, named geoms; collision only if not visual)."""
    path = (Path(store_root) / asset.mjcf).resolve()
    key = (str(path), visual, path.stat().st_mtime if path.exists() else 0.0)
    if key not in _SPEC_CACHE:
        if not path.exists():
            raise InputError(path, f"object model of {asset.name} not found")
        try:
            spec = mujoco.MjSpec.from_file(str(path))
        except Exception as e:  # mujoco raises ValueError with the parser message
            raise InputError(path, f"object model does not parse: {e}") from None
        _absolutise(spec, path.parent)
        body = spec.worldbody.first_body()
        if body is None:
            raise InputError(path, "object model has no body under worldbody")
        if spec.worldbody.first_joint() is not None or body.first_joint() is not None:
            raise InputError(path, "object model must not contain joints (the composer adds the freejoint)")
        for i, g in enumerate(body.geoms):
            if not g.name:
                cls = g.classname.name if g.classname is not None else ""
                g.name = f"{cls if cls and cls != 'main' else 'geom'}_{i}"
        if not visual:
            used = set()
            for g in list(body.geoms):
                if g.group != GROUP_OBJECT_COLLISION and (g.contype == 0 and g.conaffinity == 0):
                    spec.delete(g)
                else:
                    g.material = ""
                    if g.meshname:
                        used.add(g.meshname)
            for m in list(spec.meshes):
                if m.name not in used:
                    spec.delete(m)
            for mat in list(spec.materials):
                spec.delete(mat)
            for t in list(spec.textures):
                spec.delete(t)
        _SPEC_CACHE[key] = spec
    return _SPEC_CACHE[key].copy()


def load_scene_spec(scene: SceneAsset, store_root: str | Path) -> mujoco.MjSpec:
    """Return a fresh copy of the scene's visual-only spec with absolute asset paths (parsed once per file)."""
    path = (Path(store_root) / scene.mjcf).resolve()
    if not path.exists():
        raise InputError(path, f"scene model of {scene.name} not found")
    key = (str(path), "scene", path.stat().st_mtime)
    if key not in _SCENE_CACHE:
        try:
            spec = mujoco.MjSpec.from_file(str(path))
        except Exception as e:
            raise InputError(path, f"scene model does not parse: {e}") from None
        _absolutise(spec, path.parent)
        _SCENE_CACHE.clear()  # one scene at a time: a worker's variants mostly share it
        _SCENE_CACHE[key] = spec
    return _SCENE_CACHE[key].copy()


def set_physics_options(spec: mujoco.MjSpec, cfg: PlaceConfig) -> None:
    """Set the settling options: timestep, implicitfast, Newton, pyramidal cone, multiccd on."""
    spec.option.timestep = cfg.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    if cfg.sleep:
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    else:
        spec.option.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)


def compose(placements: list[Placement], assets: dict[str, ObjectAsset], planes: list[ReceptaclePlane],
            scene: SceneAsset | None, store_root: str | Path, cfg: PlaceConfig, with_scene: bool = False,
            visual: bool = False) -> Composed:
    """Build and compile scene (optional) + support + objects at their spawn poses (or settled poses if set).

    Parameters
    ----------
    placements : list of Placement
        Objects to add, at their settled poses when set, else their spawn poses (world metres, wxyz).
    assets : dict of str to ObjectAsset
        Object assets by name.
    planes : list of ReceptaclePlane
        Receptacle planes (support geometry is added for each).
    scene : SceneAsset or None
        The scene (floors; its visual model when `with_scene`).
    store_root : str or Path
        Store root the assets' files are relative to.
    cfg : PlaceConfig
        Physics and support settings.
    with_scene : bool
        Include the scene's own (visual) model.
    visual : bool
        Include the objects' visual meshes (not only their collision hulls).
    """
    spec = load_scene_spec(scene, store_root) if (with_scene and scene is not None) else mujoco.MjSpec()
    if not with_scene:
        spec.modelname = f"{scene.name if scene is not None else 'scene'}_settle"
    set_physics_options(spec, cfg)
    support = add_support(spec, planes, scene, cfg, store_root)
    frame = spec.worldbody.add_frame()
    for p in placements:
        child = load_object_spec(assets[p.asset], store_root, visual=visual)
        body = frame.attach_body(child.worldbody.first_body(), f"{p.object_id}/", "")
        body.name = p.object_id
        pos = p.settled_pos if p.settled_pos is not None else p.spawn_pos
        quat = p.settled_quat if p.settled_quat is not None else p.spawn_quat
        body.pos = [float(v) for v in pos]
        body.quat = [float(v) for v in quat]
        body.add_freejoint(name=f"{p.object_id}/free")
    try:
        model = spec.compile()
    except Exception as e:
        raise InputError(store_root, f"composed model does not compile: {e}") from None
    ids, qa, va, bids = [], [], [], []
    for p in placements:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
        jid = int(model.body_jntadr[bid])
        ids.append(p.object_id)
        bids.append(int(bid))
        qa.append(int(model.jnt_qposadr[jid]))
        va.append(int(model.jnt_dofadr[jid]))
    return Composed(spec, model, support, ids, qa, va, bids)


def write_mjcf(spec: mujoco.MjSpec, path: str | Path) -> Path:
    """Write a composed spec as MJCF whose asset paths are relative to the file (atomically)."""
    from ..store import atomic_write_text

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    xml = spec.to_xml()
    base = path.parent.resolve()
    done: dict[str, str] = {}  # a scene names the same few files many times

    def rel(m: re.Match[str]) -> str:
        f = m.group(2)
        if os.path.isabs(f):
            if f not in done:
                done[f] = Path(os.path.relpath(f, base)).as_posix()
            f = done[f]
        return m.group(1) + f + m.group(3)

    atomic_write_text(path, _FILE_ATTR.sub(rel, xml))
    return path


def object_qpos(model: mujoco.MjModel, data: mujoco.MjData, composed: Composed) -> np.ndarray:
    """Return the objects' free-joint qpos (N, 7) in placement order."""
    return np.array([data.qpos[a:a + 7] for a in composed.qpos_adr]).reshape(-1, 7)
