"""`sdovon-mj convert`: objects and scenes to MJCF, by the configured converter plugin (default ``mesh``)."""

from __future__ import annotations

import argparse

from ..stages import converter


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the converter's options."""
    converter().add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Run the converter's command."""
    return int(converter().run(args) or 0)
