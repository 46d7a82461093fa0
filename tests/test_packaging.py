"""The project's metadata agrees with itself: the add-on's version is declared once for
Blender (blender_manifest.toml) and once for pip (pyproject.toml), and the CHANGELOG has
an entry for it."""

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_versions_agree_and_the_changelog_names_the_release():
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["version"] == manifest["version"]
    assert f"## {manifest['version']}" in (ROOT / "CHANGELOG.md").read_text()
    assert manifest["id"] == "isoparam" and manifest["blender_version_min"] == "4.2.0"
