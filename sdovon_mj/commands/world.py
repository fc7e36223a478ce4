"""`sdovon-mj world`: write default-world homes (apartments or houses) and the object library as input files."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare world's options."""
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="home seeds")
    p.add_argument("--preset", choices=("apartment", "house"), default="apartment",
                   help="apartment (3-6 rooms) or house (8-16 rooms over 1-3 storeys: docs/world.md)")
    p.add_argument("--mode", choices=("clean", "scan", "hm3d", "mp3d", "habitat"), default="clean",
                   help="clean GLB, noisy ScanNet-style PLY, HM3D-Semantics or Matterport3D files, or a Habitat scene dataset")
    p.add_argument("--floors", type=int, choices=(0, 1, 2, 3), default=0, help="storeys (0 = seeded choice; 3: houses)")
    p.add_argument("--objects", action="store_true", help="also write the object library")
    p.add_argument("--object-seed", type=int, default=0)
    p.add_argument("--variants", type=int, default=3, help="shape variants per object category")


def run(args: argparse.Namespace) -> int:
    """Write the requested homes (and objects) and print their paths."""
    from ..errors import UsageError
    from ..world import generate_home, write_apartment, write_object_library
    from ..world.presets import preset

    if args.floors == 3 and args.preset != "house":
        raise UsageError("--floors 3: only houses have 3 storeys (--preset house)")
    out = Path(args.out)
    stem = preset(args.preset).scene
    for seed in args.seeds:
        home = generate_home(seed, args.preset, floors=args.floors or None)
        print(write_apartment(home, out / f"{stem}_{seed:04d}", mode=args.mode, name=f"{stem}_{seed:04d}"))
    if args.objects:
        paths = write_object_library(args.object_seed, out / "objects", variants=args.variants)
        print(f"{len(paths)} objects -> {out / 'objects'}")
    return 0
