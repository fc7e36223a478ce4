"""Settle placed objects with MuJoCo physics and classify where each came to rest.

Settings (docs/background.md, "Physics settling", measured there: 9 objects settle in 0.85 s of
sim time, 0.04-0.09 s wall): timestep `PlaceConfig.timestep` (2 ms), `implicitfast` integrator,
Newton solver, pyramidal friction cone, multiccd on (without it a standing can never settles), and
support geoms with torsional + rolling friction (condim 6) so round objects stop rolling.

One model per variant; `mj_step` runs `check_every` steps at a time between speed checks. An object
is still when its linear speed < `lin_vel_tol` and angular speed < `ang_vel_tol`; the variant is
settled when every live object has been still for `settle_window` (cap: `max_settle_time`). Objects
touching a floor are classified as fallen at once and taken out of the simulation (no contacts,
gravity compensated), so nobody waits for them to stop rolling on the floor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..config import PlaceConfig
from ..records import Placement, ReceptaclePlane
from .compose import Composed
from ..geometry import points_in_convex_polygon

RESTING = "resting"
ELSEWHERE = "resting_elsewhere"
FELL = "fell"
UNSTABLE = "unstable"
SINK_TOL = 0.002  # m: a centre of mass this far below its plane's top face means the object is stuck in it
SINK_DEPTH_TOL = 0.005  # m: deeper contact penetration into a support means the object is stuck in it


@dataclass
class SettleStats:
    """What one settle call cost and reached."""

    sim_time: float = 0.0
    wall_time: float = 0.0
    steps: int = 0
    settled: bool = False


@dataclass
class Verdict:
    """Where one object came to rest (status per Placement.status) and why."""

    status: str
    reason: str = ""
    touching: list[str] = field(default_factory=list)


class Settler:
    """Runs and classifies settling on one composed model; objects can be respawned and parked."""

    def __init__(self, composed: Composed, placements: list[Placement], planes: list[ReceptaclePlane], cfg: PlaceConfig) -> None:
        self.c = composed
        self.m = composed.model
        self.d = mujoco.MjData(self.m)
        self.cfg = cfg
        self.placements = placements
        self.planes = {p.id: p for p in planes}
        self.live = np.ones(len(placements), dtype=bool)
        self.fell_early: dict[int, str] = {}
        self.geom_body = np.asarray(self.m.geom_bodyid)
        self.body_index = {b: i for i, b in enumerate(composed.body_ids)}
        names = [mujoco.mj_id2name(self.m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(self.m.ngeom)]
        self.geom_names = names
        self.floor_geoms = {mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in composed.support.floors.values()}
        self.plane_geom = {pid: mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_GEOM, n) for pid, n in composed.support.planes.items()}
        self.va = np.asarray(composed.qvel_adr, dtype=int)
        self.support_geoms = np.array(sorted(self.floor_geoms | set(self.plane_geom.values())), dtype=int)
        self.contype0 = self.m.geom_contype.copy()
        self.conaffinity0 = self.m.geom_conaffinity.copy()
        self.gravcomp0 = self.m.body_gravcomp.copy()
        self.still = np.zeros(len(placements))
        self.obj_of_body = np.full(self.m.nbody, -1, dtype=np.int64)  # body id -> placement index (-1: none)
        for b, i in self.body_index.items():
            self.obj_of_body[b] = i
        self._state = 0  # bumped whenever the contact list changes (mj_step / mj_forward)
        self._touching: tuple[int, list[set[int]]] | None = None
        mujoco.mj_forward(self.m, self.d)

    # -- state ---------------------------------------------------------------------------------

    def set_pose(self, i: int, pos: np.ndarray, quat: np.ndarray) -> None:
        """Put object i at a pose with zero velocity."""
        a, v = self.c.qpos_adr[i], self.c.qvel_adr[i]
        self.d.qpos[a:a + 3] = pos
        self.d.qpos[a + 3:a + 7] = np.asarray(quat, float) / np.linalg.norm(quat)
        self.d.qvel[v:v + 6] = 0.0

    def pose(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Return object i's body position and wxyz quaternion."""
        a = self.c.qpos_adr[i]
        return self.d.qpos[a:a + 3].copy(), self.d.qpos[a + 3:a + 7].copy()

    def park(self, i: int) -> None:
        """Take object i out of the simulation: no contacts, no gravity, no motion."""
        self.live[i] = False
        b = self.c.body_ids[i]
        geoms = np.nonzero(self.geom_body == b)[0]
        self.m.geom_contype[geoms] = 0
        self.m.geom_conaffinity[geoms] = 0
        self.m.body_gravcomp[b] = 1.0
        v = self.c.qvel_adr[i]
        self.d.qvel[v:v + 6] = 0.0

    def unpark(self, i: int) -> None:
        """Put a parked object i back into the simulation."""
        self.live[i] = True
        b = self.c.body_ids[i]
        geoms = np.nonzero(self.geom_body == b)[0]
        self.m.geom_contype[geoms] = self.contype0[geoms]
        self.m.geom_conaffinity[geoms] = self.conaffinity0[geoms]
        self.m.body_gravcomp[b] = self.gravcomp0[b]
        self.fell_early.pop(i, None)

    def zero_velocities(self) -> None:
        """Stop every object (used before a resampling round)."""
        self.d.qvel[:] = 0.0

    # -- simulate ------------------------------------------------------------------------------

    def refresh_contacts(self) -> None:
        """Recompute contacts for every object, sleeping ones included (sleep hides their contacts)."""
        sleep = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        flags = int(self.m.opt.enableflags)
        self.m.opt.enableflags = flags & ~sleep
        mujoco.mj_forward(self.m, self.d)
        self._state += 1
        self.m.opt.enableflags = flags

    def _contacts(self) -> list[set[int]]:
        """Return, per object, the set of geom ids it touches (other bodies only; computed once per state)."""
        if self._touching is not None and self._touching[0] == self._state:
            return self._touching[1]
        out: list[set[int]] = [set() for _ in self.placements]
        n = self.d.ncon
        if n:
            g = np.asarray(self.d.contact.geom[:n])
            for a, b in ((0, 1), (1, 0)):
                obj = self.obj_of_body[self.geom_body[g[:, a]]]
                mine = obj >= 0
                for i, other in zip(obj[mine].tolist(), g[mine, b].tolist()):
                    out[i].add(other)
        self._touching = (self._state, out)
        return out

    def support_penetration(self, i: int) -> float:
        """Return how deep (m) object i's geoms penetrate any support geom (0 when not at all)."""
        n = self.d.ncon
        if n == 0:
            return 0.0
        b = self.c.body_ids[i]
        g = np.asarray(self.d.contact.geom[:n])
        dist = np.asarray(self.d.contact.dist[:n])
        supports = self.support_geoms
        mine = ((self.geom_body[g[:, 0]] == b) & np.isin(g[:, 1], supports)) | ((self.geom_body[g[:, 1]] == b) & np.isin(g[:, 0], supports))
        return float(max(-dist[mine].min(), 0.0)) if mine.any() else 0.0

    def run(self) -> SettleStats:
        """Step until every live object stays still for the window or the time cap; return the stats."""
        cfg, m, d = self.cfg, self.m, self.d
        t0 = time.perf_counter()
        n = max(int(cfg.check_every), 1)
        dt = float(m.opt.timestep)
        still = np.zeros(len(self.placements))
        steps_cap = int(np.ceil(cfg.max_settle_time / dt))
        steps = 0
        settled = False
        while steps < steps_cap:
            mujoco.mj_step(m, d, nstep=n)
            self._state += 1
            steps += n
            if len(self.va) == 0:
                settled = True
                break
            qv = d.qvel
            lin = np.linalg.norm(np.stack([qv[self.va], qv[self.va + 1], qv[self.va + 2]], axis=1), axis=1)
            ang = np.linalg.norm(np.stack([qv[self.va + 3], qv[self.va + 4], qv[self.va + 5]], axis=1), axis=1)
            ok = (lin < cfg.lin_vel_tol) & (ang < cfg.ang_vel_tol)
            still = np.where(ok, still + n * dt, 0.0)
            if self.floor_geoms:
                touching = self._contacts()
                for i in np.nonzero(self.live)[0]:
                    if touching[i] & self.floor_geoms:
                        self.fell_early[int(i)] = "touched the floor while settling"
                        self.park(int(i))
            if np.all(still[self.live] >= cfg.settle_window - 1e-9):
                settled = True
                break
        self.still = still
        self.refresh_contacts()
        return SettleStats(sim_time=steps * dt, wall_time=time.perf_counter() - t0, steps=steps, settled=settled)

    def classify(self, i: int) -> Verdict:
        """Return where live or early-fallen object i ended up."""
        p = self.placements[i]
        if i in self.fell_early:
            return Verdict(FELL, self.fell_early[i])
        plane = self.planes[p.plane_id]
        touching = self._contacts()[i]
        names = sorted(self.geom_names[g] or f"geom {g}" for g in touching)
        com = self.d.xipos[self.c.body_ids[i]]
        if touching & self.floor_geoms:
            return Verdict(FELL, "rests on the floor", names)
        if com[2] < plane.height - self.cfg.fell_drop:
            return Verdict(FELL, f"centre {plane.height - com[2]:.2f} m below its plane", names)
        if self.still[i] < self.cfg.settle_window - 1e-9:
            v = self.c.qvel_adr[i]
            return Verdict(UNSTABLE, f"still moving after {self.cfg.max_settle_time:.1f} s "
                                     f"(|v| {np.linalg.norm(self.d.qvel[v:v + 3]):.3f} m/s, |w| {np.linalg.norm(self.d.qvel[v + 3:v + 6]):.2f} rad/s)", names)
        depth = self.support_penetration(i)
        if depth > SINK_DEPTH_TOL:
            return Verdict(UNSTABLE, f"sunk {100 * depth:.1f} cm into a support", names)
        if com[2] < plane.height - SINK_TOL:
            # A centre of mass under the support's top face: the object got pushed into (or through) it.
            return Verdict(UNSTABLE, f"sunk into its support (centre {100 * (plane.height - com[2]):.1f} cm below the plane)", names)
        gid = self.plane_geom.get(p.plane_id, -2)
        if gid in touching and points_in_convex_polygon(plane.polygon, com[:2], tol=0.01)[0]:
            return Verdict(RESTING, "", names)
        if gid in touching:
            return Verdict(ELSEWHERE, "centre overhangs its plane's edge", names)
        what = ", ".join(names) if names else "nothing"
        return Verdict(ELSEWHERE, f"not on its plane; touching {what}", names)
