"""`sdovon-mj world`: write default-world apartments and the object library as input files."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare world's options."""
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="apartment seeds")
    p.add_argument("--mode", choices=("clean", "scan", "hm3d", "mp3d", "habitat"), default="clean",
                   help="clean GLB, noisy ScanNet-style PLY, HM3D-Semantics or Matterport3D files, or a Habitat scene dataset")
    p.add_argument("--floors", type=int, choices=(0, 1, 2), default=0, help="storeys (0 = seeded choice)")
    p.add_argument("--objects", action="store_true", help="also write the object library")
    p.add_argument("--object-seed", type=int, default=0)
    p.add_argument("--variants", type=int, default=3, help="shape variants per object category")


def run(args: argparse.Namespace) -> int:
    """Write the requested apartments (and objects) and print their paths."""
    from ..world import generate_apartment, write_apartment, write_object_library

    out = Path(args.out)
    for seed in args.seeds:
        apt = generate_apartment(seed, floors=args.floors or None)
        print(write_apartment(apt, out / f"apt_{seed:04d}", mode=args.mode, name=f"apt_{seed:04d}"))
    if args.objects:
        paths = write_object_library(args.object_seed, out / "objects", variants=args.variants)
        print(f"{len(paths)} objects -> {out / 'objects'}")
    return 0
