"""USD exporter (Isaac Sim / Isaac Lab): one layered USD stage per variant, UsdPhysics schemas, ObjectNav JSON.

Layout under ``<out>/<name>/`` (Z up, metres, kilograms)::

    scenes/<scene>.usdc         the static scene, written once per scene: visual meshes with UsdPreviewSurface
                                materials; structure meshes (MJCF group 0) are colliders, approximation "none"
    objects/<asset>.usdc        one object, written once per asset: defaultPrim /Object with RigidBodyAPI and
                                MassAPI (mass, centre of mass, diagonal inertia, principal axes from MuJoCo),
                                visual meshes and its convex hulls as colliders (approximation "convexHull")
    textures/<digest>.png       every texture, once (materials point at them relatively)
    variants/<variant>.usda     a small layer: PhysicsScene (gravity), a reference to the scene, the support
                                colliders the objects were settled on, and /World/Objects/<obj_n> referencing
                                its object asset at the settled pose (translate + orient)
    episodes/<variant>.json     the variant's ObjectNav episodes (records) with each goal's ``prim_path``
    index.json                  dataset, split, one entry per variant (stage, episodes, object prim paths)

Variants without episodes (no valid goals) are skipped and reported, like the Habitat and MJCF exporters.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from sdovon_mj.records import dumps
from sdovon_mj.store import atomic_write_bytes, atomic_write_text
from sdovon_mj.export import ExportOptions, ExportReport, Exporter, RunView, exportable_variants, finish_export

from exporters.simparts import MeshPart, RigidBody, VariantParts, texture_png, variant_parts

try:
    from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt
except ImportError as e:  # pragma: no cover - depends on the optional extra
    raise ImportError("the usd exporter needs usd-core: pip install 'sdovon-mj[sim-export]'") from e

OBJECT_ROOT = "/World/Objects"


def _name(s: str, used: set[str]) -> str:
    """Return a valid, unique prim name for s."""
    base = Tf.MakeValidIdentifier(s)
    name, k = base, 1
    while name in used:
        name, k = f"{base}_{k}", k + 1
    used.add(name)
    return name


def _save(stage: Usd.Stage, path: Path) -> Path:
    """Save a stage made by `_new_stage` and move its file onto path atomically."""
    layer = stage.GetRootLayer()
    tmp = layer.realPath
    if not layer.Save():
        raise OSError(f"USD could not write {path}")
    os.replace(tmp, path)
    return path


def _new_stage(root: str, path: Path) -> tuple[Usd.Stage, Usd.Prim]:
    """Return a new stage (Z up, metres, kg) with an Xform default prim at /root, backed by a temporary file
    beside `path` (relative asset paths resolve as they will from `path`; `_save` moves it there)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    os.unlink(tmp)
    stage = Usd.Stage.CreateNew(tmp)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    prim = UsdGeom.Xform.Define(stage, f"/{root}").GetPrim()
    stage.SetDefaultPrim(prim)
    return stage, prim


class _Writer:
    """Writes meshes and their materials into one stage; textures go to the dataset's textures/ once."""

    def __init__(self, stage: Usd.Stage, root: str, layer_dir: Path, tex_dir: Path, written: list[Path]) -> None:
        self.stage, self.root, self.layer_dir, self.tex_dir = stage, root, layer_dir, tex_dir
        self.written = written
        self.looks: dict[tuple, UsdShade.Material] = {}
        self.used: set[str] = set()
        UsdGeom.Scope.Define(stage, f"{root}/Looks")

    def texture(self, part: MeshPart) -> str:
        """Return the layer-relative path of a part's texture PNG (written on first use)."""
        png = texture_png(part.image)

        p = self.tex_dir / f"{hashlib.sha256(png).hexdigest()[:16]}.png"
        if not p.exists():
            atomic_write_bytes(p, png)
        self.written.append(p)
        return os.path.relpath(p, self.layer_dir).replace(os.sep, "/")

    def material(self, part: MeshPart) -> UsdShade.Material:
        """Return the UsdPreviewSurface material of a part (shared by parts of equal colour and texture)."""
        key = (tuple(np.round(part.rgba, 4)), part.texture)
        if key in self.looks:
            return self.looks[key]
        path = f"{self.root}/Looks/M{len(self.looks):03d}"
        mat = UsdShade.Material.Define(self.stage, path)
        sh = UsdShade.Shader.Define(self.stage, f"{path}/Surface")
        sh.CreateIdAttr("UsdPreviewSurface")
        rgba = [float(x) for x in part.rgba]
        sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.8)
        sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(rgba[3])
        if part.texture >= 0:
            st = UsdShade.Shader.Define(self.stage, f"{path}/PrimvarSt")
            st.CreateIdAttr("UsdPrimvarReader_float2")
            st.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
            tx = UsdShade.Shader.Define(self.stage, f"{path}/Texture")
            tx.CreateIdAttr("UsdUVTexture")
            tx.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(self.texture(part)))
            tx.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
            tx.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*rgba))  # MuJoCo: texture x rgba
            tx.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st.ConnectableAPI(), "result")
            tx.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
            sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tx.ConnectableAPI(), "rgb")
        else:
            sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgba[:3]))
        mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
        self.looks[key] = mat
        return mat

    def mesh(self, parent: str, part: MeshPart, visual: bool, collider: str | None) -> UsdGeom.Mesh:
        """Define a Mesh prim for a part under parent (visual: bound material; collider: approximation or None)."""
        mesh = UsdGeom.Mesh.Define(self.stage, f"{parent}/{_name(part.name, self.used)}")
        v = np.asarray(part.vertices, dtype=np.float32)
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(v))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(part.faces)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(part.faces, dtype=np.int32).ravel()))
        mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, v.min(0))), Gf.Vec3f(*map(float, v.max(0)))]))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        if visual:
            if part.uv is not None and part.face_uv is not None:
                pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                             UsdGeom.Tokens.faceVarying)
                pv.Set(Vt.Vec2fArray.FromNumpy(np.asarray(part.uv, dtype=np.float32)))
                pv.SetIndices(Vt.IntArray.FromNumpy(np.asarray(part.face_uv, dtype=np.int32).ravel()))
            mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, part.rgba[:3]))]))
            UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(self.material(part))
        else:
            mesh.CreatePurposeAttr(UsdGeom.Tokens.guide)  # colliders are not rendered
        if collider is not None:
            UsdPhysics.CollisionAPI.Apply(mesh.GetPrim())
            UsdPhysics.MeshCollisionAPI.Apply(mesh.GetPrim()).CreateApproximationAttr(collider)
        return mesh


def scene_stage(parts: VariantParts, path: Path, tex_dir: Path, written: list[Path]) -> Path:
    """Write the static scene asset (visual meshes; group-0 meshes collide, approximation "none")."""
    stage, _ = _new_stage("Scene", path)
    w = _Writer(stage, "/Scene", path.parent, tex_dir, written)
    UsdGeom.Scope.Define(stage, "/Scene/Geom")
    for part in parts.scene:
        w.mesh("/Scene/Geom", part, visual=True, collider=UsdPhysics.Tokens.none if part.collides else None)
    return _save(stage, path)


def object_stage(body: RigidBody, path: Path, tex_dir: Path, written: list[Path]) -> Path:
    """Write one object asset: a rigid body with mass properties, visual meshes and convex-hull colliders."""
    stage, prim = _new_stage("Object", path)
    UsdPhysics.RigidBodyAPI.Apply(prim)
    mass = UsdPhysics.MassAPI.Apply(prim)
    mass.CreateMassAttr(float(body.mass))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(*map(float, body.com)))
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(*map(float, body.inertia)))
    q = [float(x) for x in body.principal_quat]
    mass.CreatePrincipalAxesAttr(Gf.Quatf(q[0], q[1], q[2], q[3]))
    w = _Writer(stage, "/Object", path.parent, tex_dir, written)
    UsdGeom.Scope.Define(stage, "/Object/Visuals")
    UsdGeom.Scope.Define(stage, "/Object/Collisions")
    for part in body.visuals:
        w.mesh("/Object/Visuals", part, visual=True, collider=None)
    for part in body.collisions:
        w.mesh("/Object/Collisions", part, visual=False, collider=UsdPhysics.Tokens.convexHull)
    return _save(stage, path)


def variant_stage(parts: VariantParts, path: Path, scene_file: Path, object_files: dict[str, Path]) -> dict[str, str]:
    """Write a variant layer (physics scene, scene reference, support colliders, posed objects); return prim paths."""
    stage, _ = _new_stage("World", path)
    g = np.asarray(parts.gravity, dtype=float)
    ps = UsdPhysics.Scene.Define(stage, "/World/PhysicsScene")
    norm = float(np.linalg.norm(g))
    ps.CreateGravityDirectionAttr(Gf.Vec3f(*map(float, g / norm)) if norm > 0 else Gf.Vec3f(0.0, 0.0, -1.0))
    ps.CreateGravityMagnitudeAttr(norm)
    rel = lambda p: os.path.relpath(p, path.parent).replace(os.sep, "/")  # noqa: E731
    scene = UsdGeom.Xform.Define(stage, "/World/Scene").GetPrim()
    scene.GetReferences().AddReference(rel(scene_file))
    UsdGeom.Scope.Define(stage, "/World/Support")
    w = _Writer(stage, "/World", path.parent, path.parent, [])
    for part in parts.support:
        w.mesh("/World/Support", part, visual=False, collider=UsdPhysics.Tokens.none)
    UsdGeom.Scope.Define(stage, OBJECT_ROOT)
    prims: dict[str, str] = {}
    used: set[str] = set()
    for body in parts.bodies:
        ppath = f"{OBJECT_ROOT}/{_name(body.object_id, used)}"
        x = UsdGeom.Xform.Define(stage, ppath)
        x.GetPrim().GetReferences().AddReference(rel(object_files[body.asset]))
        x.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*map(float, body.pos)))
        q = [float(v) for v in body.quat]
        x.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(q[0], q[1], q[2], q[3]))
        x.GetPrim().SetCustomDataByKey("sdovon:category", body.category)
        x.GetPrim().SetCustomDataByKey("sdovon:asset", body.asset)
        prims[body.object_id] = ppath
    _save(stage, path)
    return prims


class UsdExporter(Exporter):
    """Writes layered USD stages (scene and objects once, a small layer per variant) and episode JSON."""

    name = "usd"

    def export(self, run: RunView, out_dir: Path, options: ExportOptions) -> ExportReport:
        """Write every variant with episodes as a USD stage under out_dir/<name>/ (layout: module docstring)."""
        root = Path(out_dir) / options.name
        tex_dir = root / "textures"
        report = ExportReport(format=self.name, out_dir=str(out_dir), name=options.name)
        written: list[Path] = []
        scenes: dict[str, Path] = {}
        objects: dict[str, Path] = {}
        index = []
        for variant, eps in exportable_variants(run, report):
            parts = variant_parts(run, variant)
            if variant.scene not in scenes:
                scenes[variant.scene] = scene_stage(parts, root / "scenes" / f"{variant.scene}.usdc", tex_dir, written)
                written.append(scenes[variant.scene])
            for body in parts.bodies:
                if body.asset not in objects:
                    objects[body.asset] = object_stage(body, root / "objects" / f"{body.asset}.usdc", tex_dir, written)
                    written.append(objects[body.asset])
            vpath = root / "variants" / f"{variant.name}.usda"
            prims = variant_stage(parts, vpath, scenes[variant.scene], objects)
            written.append(vpath)
            ep_dicts = [e.to_dict() for e in eps]
            for e in ep_dicts:
                for goal in e["goals"]:
                    goal["prim_path"] = prims.get(goal["object_id"], "")
            epath = root / "episodes" / f"{variant.name}.json"
            atomic_write_text(epath, dumps({"stage": f"variants/{variant.name}.usda", "object_prims": prims,
                                            "frame": "Z up, metres; quaternions wxyz; positions are the agent base on the floor",
                                            "episodes": ep_dicts}))
            written.append(epath)
            index.append({"variant": variant.name, "stage": f"variants/{variant.name}.usda",
                          "episodes": f"episodes/{variant.name}.json", "n_episodes": len(eps), "object_prims": prims})
            report.variants.append(variant.name)
            report.episodes += len(eps)
        return finish_export(report, root, options, index, written)


__all__ = ["UsdExporter", "scene_stage", "object_stage", "variant_stage", "OBJECT_ROOT"]
