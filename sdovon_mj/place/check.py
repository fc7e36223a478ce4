"""Independent check of a written variant, apart from the settle loop: load the composed MJCF from
disk, set the stored qpos, and for every object ask MuJoCo directly

- does a ray cast straight down from its centre of mass (through object and support collision
  geoms, own body excluded) first hit its intended receptacle's support geometry, within 2 cm of
  the plane height?
- is it in contact with that support geometry?
- how deep does it penetrate other objects (contact distance)?
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..errors import InputError
from ..records import ReceptaclePlane, SceneVariant
from ..sim import GROUP_OBJECT_COLLISION, GROUP_SUPPORT
from .support import plane_geom_name

RAY_TOL = 0.02  # m: the ray's hit must lie this close to the intended plane height
PENETRATION_TOL = 0.005  # m: allowed interpenetration between two objects


@dataclass
class ObjectCheck:
    """The independent verdict on one placed object."""

    object_id: str
    category: str
    status: str  # the settle loop's status (for reference)
    ok: bool
    hit: str = ""  # name of the first geom the downward ray hits
    hit_gap: float = float("nan")  # |hit height - plane height|, m
    in_contact: bool = False
    reason: str = ""


@dataclass
class VariantCheck:
    """The independent verdicts on a variant and its worst object-object penetration."""

    variant: str
    objects: list[ObjectCheck] = field(default_factory=list)
    max_penetration: float = 0.0
    penetrations: list[tuple[str, str, float]] = field(default_factory=list)  # pairs deeper than PENETRATION_TOL

    @property
    def ok_count(self) -> int:
        """Return how many objects passed."""
        return sum(o.ok for o in self.objects)


def _body_of(name: str) -> str:
    """Return the object id ('obj_<n>') of a geom/body name, or ''."""
    head = name.split("/", 1)[0]
    return head if head.startswith("obj_") else ""


def check_variant(variant: SceneVariant, planes: list[ReceptaclePlane], store_root: str | Path) -> VariantCheck:
    """Check every placement of a written variant against its model file; dropped ones fail."""
    path = Path(store_root) / variant.mjcf
    if not variant.mjcf or not path.exists():
        raise InputError(path, f"variant {variant.name} has no composed model on disk")
    model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    data = mujoco.MjData(model)
    if variant.qpos is not None and len(variant.qpos):
        if len(variant.qpos) != model.nq:
            raise InputError(path, f"variant qpos has {len(variant.qpos)} values, the model {model.nq}")
        data.qpos[:] = variant.qpos
    mujoco.mj_forward(model, data)
    heights = {p.id: p.height for p in planes}
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(model.ngeom)]
    bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in range(model.nbody)]
    geom_obj = [_body_of(bodies[int(model.geom_bodyid[g])]) or _body_of(names[g]) for g in range(model.ngeom)]
    touching: dict[str, set[str]] = {}
    out = VariantCheck(variant=variant.name)
    deepest: dict[tuple[str, str], float] = {}
    for k in range(data.ncon):
        c = data.contact[k]
        g1, g2 = int(c.geom[0]), int(c.geom[1])
        o1, o2 = geom_obj[g1], geom_obj[g2]
        if o1:
            touching.setdefault(o1, set()).add(names[g2])
        if o2:
            touching.setdefault(o2, set()).add(names[g1])
        if o1 and o2 and o1 != o2:
            depth = max(-float(c.dist), 0.0)
            key = tuple(sorted((o1, o2)))
            deepest[key] = max(deepest.get(key, 0.0), depth)  # type: ignore[index]
    for (a, b), d in sorted(deepest.items()):
        out.max_penetration = max(out.max_penetration, d)
        if d > PENETRATION_TOL:
            out.penetrations.append((a, b, d))
    groups = np.zeros(6, dtype=np.uint8)
    groups[GROUP_OBJECT_COLLISION] = 1
    groups[GROUP_SUPPORT] = 1
    gid = np.zeros(1, dtype=np.int32)
    for p in variant.placements:
        if p.status != "resting":
            out.objects.append(ObjectCheck(p.object_id, p.category, p.status, False, reason=f"not in the model ({p.status}: {p.reason})"))
            continue
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p.object_id)
        if bid < 0:
            out.objects.append(ObjectCheck(p.object_id, p.category, p.status, False, reason="body missing from the model"))
            continue
        com = data.xipos[bid].copy()
        dist = mujoco.mj_ray(model, data, com, np.array([0.0, 0.0, -1.0]), groups, 1, bid, gid)
        want = plane_geom_name(p.plane_id)
        hit = names[int(gid[0])] if dist >= 0 and gid[0] >= 0 else ""
        gap = abs((com[2] - dist) - heights.get(p.plane_id, np.nan)) if dist >= 0 else float("nan")
        contact = want in touching.get(p.object_id, set())
        ok = hit == want and gap <= RAY_TOL and contact
        why = "" if ok else "; ".join(x for x in (
            f"ray hits {hit or 'nothing'}, not {want}" if hit != want else "",
            f"ray hit {gap:.3f} m from the plane height" if hit == want and not gap <= RAY_TOL else "",
            "no contact with its support" if not contact else "") if x)
        out.objects.append(ObjectCheck(p.object_id, p.category, p.status, bool(ok), hit, float(gap), contact, why))
    return out


def per_category(checks: list[VariantCheck]) -> dict[str, tuple[int, int]]:
    """Return per category (passed, placed) over many variant checks."""
    out: dict[str, list[int]] = {}
    for vc in checks:
        for o in vc.objects:
            a = out.setdefault(o.category, [0, 0])
            a[0] += int(o.ok)
            a[1] += 1
    return {k: (v[0], v[1]) for k, v in sorted(out.items())}


def format_report(checks: list[VariantCheck]) -> str:
    """Return a small text table: per category passed/placed and the worst penetration."""
    rows = per_category(checks)
    tot_ok = sum(v[0] for v in rows.values())
    tot = sum(v[1] for v in rows.values())
    lines = [f"{'category':<20} {'resting':>8} {'placed':>7} {'share':>7}"]
    for cat, (ok, n) in rows.items():
        lines.append(f"{cat:<20} {ok:>8} {n:>7} {ok / n:>7.1%}")
    pen = max((c.max_penetration for c in checks), default=0.0)
    lines.append(f"{'all':<20} {tot_ok:>8} {tot:>7} {(tot_ok / tot if tot else 0):>7.1%}   "
                 f"variants {len(checks)}, worst object-object penetration {pen * 1000:.2f} mm")
    return "\n".join(lines)
