"""Subcommands that wire stages together (demo, generate, show, world)."""
