"""Pictures of evaluated episodes: the trajectory, the start and the goals' view points on the top-down navigable
map."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...store import atomic_write_bytes
from ..bundle import find_bundles, load_bundle


def trajectory_picture(dataset: str | Path, result: dict, path: Path, scale: int = 4) -> None:
    """Draw an episode's trajectory, start and goal view points on the top-down navigable map (PNG)."""
    import cv2

    match = [p for p in find_bundles(dataset) if p.name == result["variant"]]
    b = load_bundle(match[0] if match else dataset)
    ep = next(e for e in b.episodes if e.episode_id == result["episode_id"])
    nm = b.navmap(ep.floor)
    img = np.full(nm.navigable.shape + (3,), 40, np.uint8)
    img[nm.free] = (150, 150, 150)
    img[nm.navigable] = (220, 220, 220)
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def px(xy):
        rc = (np.asarray(xy, float)[:2] - nm.origin) / nm.resolution * scale
        return int(rc[0]), int(rc[1])

    for g in ep.goals:
        for vp in g.view_points:
            cv2.circle(img, px(vp.position), 1, (80, 200, 80), -1)
        cv2.circle(img, px(g.position), 4, (0, 140, 0), -1)
    traj = result["trajectory"]
    for a, c in zip(traj[:-1], traj[1:]):
        cv2.line(img, px(a), px(c), (40, 40, 230), 2)
    cv2.circle(img, px(traj[0]), 5, (230, 120, 20), -1)
    cv2.circle(img, px(traj[-1]), 4, (0, 0, 255) if not result["success"] else (0, 200, 0), 2)
    img = img[::-1].copy()  # north (+Y) up
    cv2.putText(img, f"{result['agent']} {result['category']} S={result['success']:.0f} SPL={result['spl']:.2f}",
                (5, 15), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1)
    ok, buf = cv2.imencode(".png", img)
    atomic_write_bytes(path, buf.tobytes())
