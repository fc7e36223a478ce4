"""The citation: `CITATION.cff` is valid Citation File Format 1.2.0 (the schema vendored in tests/data/cff, checked
with jsonschema, offline), names this package's version, and the README's last section cites the same SD-OVON paper
as the file's reference."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import jsonschema
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "tests" / "data" / "cff" / "schema-1.2.0.json").read_text(encoding="utf-8"))


def cff_errors(data: dict) -> list[str]:
    """Return the schema's complaints about one CFF document (empty when valid)."""
    validator = jsonschema.Draft7Validator(SCHEMA, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER)
    return [f"{'/'.join(map(str, e.absolute_path)) or '(root)'}: {e.message}" for e in validator.iter_errors(data)]


def citation() -> dict:
    return yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))


def test_the_citation_file_is_valid_cff_1_2_0():
    data = citation()
    assert data["cff-version"] == "1.2.0"
    assert cff_errors(data) == []


def test_the_schema_check_rejects_what_cff_forbids():
    """The check can fail: no authors, an unknown licence and an unknown key each give an error."""
    data = citation()
    assert cff_errors({k: v for k, v in data.items() if k != "authors"})
    assert cff_errors({**data, "license": "not-a-licence"})
    assert cff_errors({**data, "citation": "unknown key"})


def test_the_citation_names_this_version_and_licence():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    data = citation()
    assert str(data["version"]) == project["version"]
    assert data["license"] == "Apache-2.0" and data["authors"] == [{"name": "sdovon-mj developers"}]


def test_the_readme_ends_with_the_citation_of_this_project_and_of_the_paper():
    """The README's last section points at CITATION.cff and gives a BibTeX entry of the paper whose title, authors
    and year are the file's reference's."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    last = text[text.rindex("\n## "):]
    assert "CITATION.cff" in last
    bib = re.search(r"```bibtex\n(@\w+\{.*?)```", last, re.S)
    assert bib, "no BibTeX block in the README's last section"
    fields = dict(re.findall(r"^\s*(\w+)\s*=\s*\{(.*)\},?\s*$", bib.group(1), re.M))
    paper = citation()["references"][0]
    assert fields["title"].replace("{", "").replace("}", "") == paper["title"]
    assert fields["year"] == str(paper["year"])
    names = [f"{a['family-names']}, {a['given-names']}" for a in paper["authors"]]
    assert [n.strip() for n in fields["author"].split(" and ")] == names
