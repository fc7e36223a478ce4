"""MJCF templates in Menagerie style (object.xml, scene.xml); see `template_path`."""

from pathlib import Path


def template_path(name: str) -> Path:
    """Return the path of a bundled MJCF template, e.g. `template_path("object.xml")`."""
    p = Path(__file__).with_name(name)
    if not p.exists():
        raise FileNotFoundError(f"no MJCF template named {name} in {p.parent}")
    return p
