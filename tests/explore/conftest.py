"""Shared helpers of the explore tests: scenario files in tests/explore/data, one run of a
scenario through the product's iteration runner (a real Session, real recording)."""

from __future__ import annotations

from pathlib import Path

import yaml

DATA = Path(__file__).resolve().parent / "data"


def write_variant(tmp_path: Path, name: str, source: str, edit: dict[str, object]) -> Path:
    """A copy of ``DATA/source`` with top-level keys replaced (``None`` deletes), written to
    ``tmp_path/name`` with absolute paths kept valid (the copy lives elsewhere)."""
    doc = yaml.safe_load((DATA / source).read_text())
    for key, value in edit.items():
        if value is None:
            doc.pop(key, None)
        else:
            doc[key] = value
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path
