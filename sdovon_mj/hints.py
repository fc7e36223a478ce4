"""Every hint the pipeline prints, in one place: what to set to what, derived from the scene's own figures.

A hint is a function of figures the run measured (floor areas, the largest navigable component, the instance
labels perception found, the farthest start an episode could draw) and of the config value it would change;
it names the ``--set KEY=VALUE`` that changes the outcome, or, where no setting can, says what the input lacks.
Each one has a test that follows it and sees the outcome change (tests/test_small_rooms.py; ``convert.add_floor``:
tests/test_artist_kitchen.py and tests/test_convert_habitat.py).

- `no_floor`: no storey found (`observe.floors.find_floors`); printed in the observe stage's refusal.
- `no_navigable_area`: storeys found but none has navigable area (`observe.navmap.navigable_map`); the same refusal.
- `no_receptacle_plane`: a scene whose perception found no receptacle plane (``generate``'s end-of-run warnings).
- `no_episodes`: a scene with receptacle planes but no episode (the same warnings).
- `empty_run`: the last line when the whole run has no episode.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Iterable, Mapping

# Labels of building pieces: never suggested as receptacles ("scene": a mesh read without instances).
STRUCTURE_LABELS = frozenset({"floor", "wall", "ceiling", "roof", "door", "window", "stairs", "scene"})


def set_option(key: str, value: object) -> str:
    """Return the command-line option that sets a config key (lists as YAML flow lists)."""
    if isinstance(value, (list, tuple)):
        value = "[" + ",".join(str(v) for v in value) + "]"
    elif isinstance(value, bool):
        value = str(value).lower()
    return f"--set {key}={value}"


def _below(x: float, step: float = 0.01) -> float:
    """Return `x` rounded down to a multiple of `step` (a setting at most the figure it comes from)."""
    return math.floor(x / step + 1e-9) * step


@dataclass(frozen=True)
class FloorFigures:
    """What one storey's navigable map measured (m^2 and m): why it has no navigable area."""

    floor: int
    floor_m2: float  # floor surface under the grid (downward rays hit it)
    free_m2: float  # floor with no obstacle in the agent's height band
    eroded_m2: float  # free area farther than the agent radius from every obstacle
    largest_m2: float  # the largest connected component of the eroded area
    widest_m: float  # the largest distance of a free cell to the nearest non-free one
    below_m: float = 0.0  # how far the scene mesh reaches below this floor


# A scene mesh reaching this far below its lowest floor found has furniture standing on no floor: the floor found is
# a table or worktop top (a floor slab's thickness or a scan's noise below the floor surface is less).
BELOW_FLOOR_M = 0.5


def no_floor(largest_up_m2: float | None, min_floor_area: float, above_m: float = 0.0) -> str:
    """Return the hint of a scene mesh with no storey.

    ``largest_up_m2`` is the largest upward-facing area at one height (None: the mesh has no upward-facing
    surface at all), ``above_m`` how far it lies above the mesh's lowest point (metres).
    """
    if largest_up_m2 is None or largest_up_m2 <= 0 or above_m > BELOW_FLOOR_M:
        what = ("the mesh has no upward-facing surface" if largest_up_m2 is None or largest_up_m2 <= 0 else
                f"its largest horizontal surface lies {above_m:.2f} m above the scene's lowest point (a furniture top)")
        return (f"{what}: a scene modelled without a floor gets one with "
                + set_option("convert.add_floor", True) + " (a ground slab under its footprint)")
    value = _below(largest_up_m2)
    if value <= 0:
        return (f"its largest horizontal surface is {largest_up_m2:.4f} m^2: the scene is in the wrong unit? "
                "(convert.units)")
    return (f"its largest horizontal surface at one height is {largest_up_m2:.2f} m^2, under observe.min_floor_area "
            f"{min_floor_area:g} m^2: a small scan passes with " + set_option("observe.min_floor_area", f"{value:.2f}"))


def no_navigable_area(figures: Iterable[FloorFigures], min_component_area: float, agent_radius: float) -> str:
    """Return the hint of a scene whose storeys have no navigable area, from the storey that comes closest."""
    figs = list(figures)
    if not figs:
        return ""
    low = min(figs, key=lambda f: f.floor)
    if low.floor == 0 and low.below_m > BELOW_FLOOR_M:
        return (f"the scene reaches {low.below_m:.2f} m below the lowest floor found, which is a furniture top: a scene "
                "modelled without a floor gets one with " + set_option("convert.add_floor", True))
    best = max(figs, key=lambda f: (f.largest_m2, f.eroded_m2, f.free_m2, f.floor_m2))
    where = f"floor {best.floor}" if len(figs) > 1 else "the floor"
    if best.largest_m2 > 0:
        value = _below(best.largest_m2)
        value = value if value > 0 else best.largest_m2
        return (f"{where}'s largest navigable component is {best.largest_m2:.2f} m^2, under observe.min_component_area "
                f"{min_component_area:g} m^2: it is kept with "
                + set_option("observe.min_component_area", f"{value:.2f}" if value >= 0.01 else f"{value:.4f}"))
    if best.free_m2 > 0:
        radius = _below(best.widest_m) - 0.01
        if radius > 0:
            return (f"{where}'s free area ({best.free_m2:.2f} m^2) is nowhere wider than the agent: its widest spot "
                    f"lies {best.widest_m:.2f} m from an obstacle and agent.radius is {agent_radius:g} m; a smaller "
                    "agent fits with " + set_option("agent.radius", f"{radius:.2f}"))
        return (f"{where}'s free area ({best.free_m2:.2f} m^2) is scattered cells between obstacles: no agent fits")
    if best.floor_m2 > 0:
        return (f"obstacles in the agent's height band cover all {best.floor_m2:.2f} m^2 of {where}: is the scene's up "
                "axis or unit wrong? (convert.up, convert.units)")
    return ("no floor surface lies under the scene's footprint at that height: a scene modelled without a floor gets "
            "one with " + set_option("convert.add_floor", True))


def no_receptacle_plane(scene: str, instance_labels: Iterable[str], receptacle_labels: Iterable[str],
                        receptacle_instances: int) -> str:
    """Return the warning of a scene with no receptacle plane, with what to set to get some.

    Parameters
    ----------
    scene : str
        The scene's name.
    instance_labels : iterable of str
        The labels of the instances perception fused (one per instance).
    receptacle_labels : iterable of str
        The run's ``receptacles.labels``.
    receptacle_instances : int
        How many of the instances were receptacles (by the labels, the LLM backend's naming or the input's word).
    """
    counts = Counter(str(lb) for lb in instance_labels)
    n = sum(counts.values())
    head = f"scene {scene}: no receptacle plane found ({n} instances): nothing can be placed"
    if not n:
        return head + ("; the scene has no instance: its input holds no labelled object (a plain mesh needs its "
                       "segmentation or a labels file beside it)")
    candidates = [lb for lb, _c in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
                  if lb.lower() not in STRUCTURE_LABELS]
    if receptacle_instances == 0 and candidates:
        shown = ", ".join(f"{lb} ({counts[lb]})" for lb in candidates[:8]) + (" ..." if len(candidates) > 8 else "")
        return (f"{head}; no instance is a receptacle: their labels are {shown}, none of them in receptacles.labels "
                f"({', '.join(receptacle_labels) or 'empty'}); to take them as receptacles: "
                + set_option("receptacles.labels", candidates))
    if receptacle_instances == 0:
        return (f"{head}; its only instances are building pieces ({', '.join(sorted(counts))}): the scene input holds "
                "no labelled furniture (a plain mesh needs its segmentation or a labels file beside it)")
    return (f"{head}; {receptacle_instances} receptacle instance(s) showed no horizontal surface that passed the "
            "plane tests (receptacles.rho_min points in a slab, receptacles.min_plane_area)")


def no_episodes(scene: str, placed: int, planes: int, farthest_start: Mapping[str, float] | None,
                min_start_distance: float, notes: Iterable[str] = ()) -> str:
    """Return the warning of a scene with receptacle planes and no episode, with what to set to get some.

    Parameters
    ----------
    scene : str
        The scene's name.
    placed, planes : int
        Objects resting in the scene's variants; its receptacle planes.
    farthest_start : mapping of str to float, optional
        Per goal category, the largest geodesic distance (m) from a navigable cell of a goal's floor to the
        category's nearest view point: the farthest start an episode could draw (None: not measured).
    min_start_distance : float
        The run's ``episodes.min_start_distance``, metres.
    notes : iterable of str
        What the place stage noted about the scene's variants (why objects were not placed).
    """
    head = f"scene {scene}: 0 episodes ({placed} objects resting on {planes} receptacle planes)"
    if placed == 0:
        why = sorted(set(notes))
        return head + ("; the place stage says: " + "; ".join(why[:3]) if why else "")
    if farthest_start is not None and not farthest_start:
        return head + "; no placed object has a goal view point (seen from a navigable spot within episodes.viewpoint_radius)"
    if farthest_start:
        far = max(farthest_start.values())
        if far < min_start_distance:
            value = max(0.05, _below(far / 2, 0.05))  # half the farthest: a band of starts to draw from
            return (f"{head}; no navigable spot lies episodes.min_start_distance {min_start_distance:g} m from a goal's "
                    f"view points (the farthest lies {far:.2f} m: a small room); starts are drawn with "
                    + set_option("episodes.min_start_distance", f"{value:.2f}"))
    return head


def empty_run(scenes: int, hinted: int) -> str:
    """Return the last line of a run with no episode: how many of its scenes have a hint above."""
    if hinted:
        return f"the run has 0 episodes: {hinted} of its {scenes} scene(s) say above what to set"
    return f"the run has 0 episodes in its {scenes} scene(s)"
