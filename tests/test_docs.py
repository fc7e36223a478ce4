"""The docs stay true to the code: the configuration reference is what the config declares, links lead somewhere."""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import make_config_docs  # noqa: E402

# Pages that other work in flight writes (the README and docs/index.md link them already).
PENDING: set[str] = set()  # pages linked before they are written (none now)
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def _pages() -> list[Path]:
    return [ROOT / n for n in ("README.md", "CONTRIBUTING.md", "CHANGELOG.md", "ARCHITECTURE.md")] + sorted(
        (ROOT / "docs").rglob("*.md"))


def _slug(heading: str) -> str:
    """Return GitHub's anchor of a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    return {_slug(m.group(1)) for m in re.finditer(r"^#+ (.+)$", page.read_text(encoding="utf-8"), re.M)}


def test_the_config_reference_is_generated_from_the_current_config():
    on_disk = (ROOT / "docs" / "config.md").read_text(encoding="utf-8")
    assert on_disk == make_config_docs.render(), "docs/config.md is stale: run `python tools/make_config_docs.py`"


def test_the_config_reference_lists_every_key_with_its_declaration():
    from sdovon_mj import config as C

    text = make_config_docs.render()
    for key, default, unit, _symbol, meaning in C.describe():
        row = next((line for line in text.splitlines() if line.startswith(f"| `{key}` |")), None)
        assert row is not None, key
        assert make_config_docs._cell(meaning) in row and make_config_docs._value(default) in row, (key, row)
    assert "| `place.k_v` | `2` | - | >= 1 | `k_v` |" in text  # range and paper symbol beside the meaning
    assert "each >= -90 and <= 90; at least 1 value" in text  # a tuple's element range and length


def test_the_generator_notices_a_changed_declaration(tmp_path, monkeypatch):
    import dataclasses

    from sdovon_mj import config as C

    before = make_config_docs.render()
    changed = dataclasses.make_dataclass("PlaceConfig", [("k_v", int, C._p(5, "-", "variants per scene", "k_v", ge=2))],
                                         frozen=True)
    monkeypatch.setattr(C, "RunConfig", dataclasses.make_dataclass(
        "RunConfig", [("place", changed, dataclasses.field(default_factory=changed))], frozen=True))
    after = make_config_docs.render()
    assert after != before and "| `place.k_v` | `5` | - | >= 2 | `k_v` | variants per scene |" in after
    out = tmp_path / "config.md"
    out.write_text(before, encoding="utf-8")
    assert make_config_docs.main(["--check", "--out", str(out)]) == 1


def test_relative_links_lead_to_files_and_headings():
    bad = []
    for page in _pages():
        for target in LINK.findall(page.read_text(encoding="utf-8")):
            if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            rel = dest.relative_to(ROOT).as_posix() if dest.is_relative_to(ROOT) else str(dest)
            if not dest.exists():
                if rel not in PENDING:
                    bad.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
                continue
            if anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
                bad.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not bad, bad
