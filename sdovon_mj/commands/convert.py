"""`sdovon-mj convert`: objects and scenes to MJCF, by the configured converter plugin (default ``mesh``)."""

from __future__ import annotations

import argparse

from .. import plugins


def _converter(name: str = "mesh"):
    """Return an instance of the converter plugin `name`."""
    obj = plugins.load("converter", name)
    return obj() if isinstance(obj, type) else obj


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the converter's options."""
    _converter().add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Run the converter's command."""
    return int(_converter().run(args) or 0)
