"""Build the Blender extension: per-platform zips bundling scipy and threadpoolctl (never numpy).

1. download the wheels that ``blender_manifest.toml`` lists (into ``wheels/``,
   kept as a cache) with ``pip download --only-binary=:all: --no-deps``;
2. stage the manifest and ``isoparam_addon/`` side by side (Blender wants the manifest
   and ``__init__.py`` at the zip root), keeping only the requested platforms' wheels;
3. validate and build with the ``blender_ext.py`` that ships inside the bpy wheel
   (no Blender binary needed), one zip per platform (``--split-platforms``).

    python scripts/build_extension.py                          # every platform, 3.11 + 3.13
    python scripts/build_extension.py --platforms linux-x64 --python 3.11
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# pip --platform tags whose wheels Blender maps to each of its platforms (newest first)
PIP_PLATFORMS = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux2014_x86_64"],
    "windows-x64": ["win_amd64"],
    "windows-arm64": ["win_arm64"],
    # Blender matches wheels by architecture only; prefer the oldest macOS minimum
    "macos-arm64": ["macosx_12_0_arm64", "macosx_14_0_arm64"],
    "macos-x64": ["macosx_10_14_x86_64", "macosx_10_15_x86_64", "macosx_11_0_x86_64", "macosx_12_0_x86_64"],
}
WHEEL_PLATFORM = {  # the platform part of the listed wheel names
    "linux-x64": "manylinux",
    "windows-x64": "win_amd64",
    "windows-arm64": "win_arm64",
    "macos-arm64": "arm64",
    "macos-x64": "x86_64",
}


def blender_ext() -> Path:
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("bpy is not installed: blender_ext.py ships inside the bpy wheel")
    base = Path(spec.submodule_search_locations[0])
    found = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise SystemExit(f"blender_ext.py not found under {base}")
    return found[-1]


def valid_tags(tool: Path) -> Path:
    return tool.parents[3] / "modules" / "_bpy_internal" / "extensions" / "tags.py"


def wheel_matches(name: str, platform: str, python: str) -> bool:
    tag = "cp" + python.replace(".", "")
    parts = name[:-4].split("-")
    plat = parts[-1]
    if plat == "any" and parts[-3].startswith("py3"):  # pure Python: every platform and Python
        return True
    if parts[-3] != tag:
        return False
    if platform == "linux-x64":
        return plat.startswith("manylinux") and plat.endswith("x86_64")
    if platform == "macos-arm64":
        return plat.startswith("macosx") and plat.endswith("arm64")
    if platform == "macos-x64":
        return plat.startswith("macosx") and plat.endswith("x86_64")
    return plat == WHEEL_PLATFORM[platform]


def download(wheels: list[str], platforms: list[str], pythons: list[str], cache: Path) -> list[str]:
    """Make sure the listed wheels for these platforms / Pythons are in ``cache``."""
    cache.mkdir(parents=True, exist_ok=True)
    wanted = []
    for platform in platforms:
        for python in pythons:  # (a pure Python wheel is listed for every pair, and kept once)
            names = [w for w in wheels if wheel_matches(Path(w).name, platform, python)]
            if not any(not Path(w).name.endswith("-any.whl") for w in names):
                raise SystemExit(f"the manifest lists no wheel for {platform}, Python {python}")
            wanted += [n for n in names if n not in wanted]
            missing = [n for n in names if not (cache / Path(n).name).exists()]
            for name in missing:  # one pip call per missing wheel
                m = re.match(r"(?P<dist>[^-]+)-(?P<ver>[^-]+)-", Path(name).name)
                cmd = [
                    sys.executable,
                    "-m",
                    "pip",
                    "download",
                    "--quiet",
                    "--disable-pip-version-check",
                    "--only-binary=:all:",
                    "--no-deps",
                    "--implementation",
                    "cp",
                    "--python-version",
                    python,
                    "-d",
                    str(cache),
                    f"{m['dist']}=={m['ver']}",
                ]
                for tag in PIP_PLATFORMS[platform]:
                    cmd += ["--platform", tag]
                subprocess.run(cmd, check=True)
                if not (cache / Path(name).name).exists():
                    got = sorted(p.name for p in cache.glob(f"{m['dist']}-{m['ver']}-*.whl"))
                    raise SystemExit(f"pip did not fetch {Path(name).name}; the cache has {got}")
    return wanted


def stage(dest: Path, wheels: list[str], cache: Path, platforms: list[str]) -> Path:
    """The manifest and the add-on's files side by side, with only the chosen wheels."""
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(ROOT / "isoparam_addon", dest, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (dest / "wheels").mkdir()
    for w in wheels:
        shutil.copy2(cache / Path(w).name, dest / "wheels" / Path(w).name)
    text = (ROOT / "blender_manifest.toml").read_text()
    listed = "wheels = [\n" + "".join(f'  "{w}",\n' for w in wheels) + "]"
    text = re.sub(r"wheels = \[.*?\]", listed, text, flags=re.S)
    text = re.sub(r"platforms = \[.*?\]", "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]", text)
    (dest / "blender_manifest.toml").write_text(text)
    return dest


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    ap.add_argument("--platforms", nargs="+", default=manifest["platforms"], choices=manifest["platforms"])
    ap.add_argument("--python", nargs="+", default=["3.11", "3.13"], choices=["3.11", "3.13"])
    ap.add_argument("--out", default="dist", help="where the zips go")
    ap.add_argument("--cache", default="wheels", help="downloaded wheels")
    args = ap.parse_args(argv)
    tool = blender_ext()
    cache, out = ROOT / args.cache, (ROOT / args.out).resolve()
    wheels = download(manifest["wheels"], args.platforms, args.python, cache)
    src = stage(ROOT / "build" / "extension", wheels, cache, args.platforms)
    out.mkdir(parents=True, exist_ok=True)
    tags = ["--valid-tags", str(valid_tags(tool))]
    subprocess.run([sys.executable, str(tool), "validate", str(src)] + tags[:0], check=True)
    subprocess.run(
        [sys.executable, str(tool), "build", "--source-dir", str(src), "--output-dir", str(out), "--split-platforms"]
        + tags,
        check=True,
    )
    zips = sorted(out.glob(f"{manifest['id']}-{manifest['version']}-*.zip"))
    for z in zips:
        print(f"{z}  {z.stat().st_size / 2**20:.1f} MiB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
