"""The extension zip: built with the bpy wheel's own tool, installed into bpy, used."""

import importlib.util
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

from .conftest import bpy  # noqa: F401 - skips this module without bpy

ROOT = Path(__file__).resolve().parents[2]

INSTALL_AND_USE = textwrap.dedent(
    """
    import sys
    import bpy, numpy as np  # BLENDER_USER_RESOURCES: a folder the test removes (~150 MB installed), numpy as np
    zip_path = sys.argv[1]
    result = bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True)
    assert result == {"FINISHED"}, result
    op = bpy.types.UV_OT_isometric_unwrap
    print("MODULE", op.__module__)
    assert op.__module__.startswith("bl_ext.user_default.isoparam"), op.__module__
    assert "isoparam_addon" not in sys.modules  # the installed copy, not the source tree
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=20, y_subdivisions=20, size=2)
    ob = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    print("RESULT", bpy.ops.uv.isometric_unwrap())
    bpy.ops.object.mode_set(mode="OBJECT")
    uv = np.empty(2 * len(ob.data.loops), np.float32)
    ob.data.uv_layers.active.uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    print("EXTENT", *np.ptp(uv, axis=0))
    """
)


@pytest.fixture(scope="module")
def linux_zip(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    cmd = [
        sys.executable,
        str(ROOT / "scripts" / "build_extension.py"),
        "--platforms",
        "linux-x64",
        "--python",
        "3.11",
        "--out",
        str(out),
    ]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    zips = list(out.glob("isoparam-*-linux_x64.zip"))
    assert len(zips) == 1, done.stdout
    return zips[0]


def test_the_zip_holds_the_manifest_the_addon_scipy_and_threadpoolctl_but_not_numpy(linux_zip):
    import zipfile

    names = zipfile.ZipFile(linux_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert any(n.startswith("solver/") for n in names) and any(n.startswith("blender/") for n in names)
    sources = {p.relative_to(ROOT / "isoparam_addon").as_posix() for p in (ROOT / "isoparam_addon").rglob("*.py")}
    assert sorted(sources - set(names)) == []  # every module, the solver's sub-packages too
    wheels = [n for n in names if n.endswith(".whl")]
    kinds = sorted(Path(w).name.split("-")[0] for w in wheels)
    assert kinds == ["scipy", "threadpoolctl"]  # one of each for this platform and Python
    assert not any("tests/" in n or "__pycache__" in n for n in names)


def test_installed_extension_unwraps_a_mesh(linux_zip):
    with tempfile.TemporaryDirectory(prefix="isoparam-ext-") as home:
        done = subprocess.run(
            [sys.executable, "-c", INSTALL_AND_USE, str(linux_zip)],
            env={**os.environ, "BLENDER_USER_RESOURCES": home},
            capture_output=True,
            text=True,
            timeout=600,
        )
    out = done.stdout + done.stderr
    assert done.returncode == 0, out
    assert "RESULT {'FINISHED'}" in out
    extent = [float(x) for x in out.split("EXTENT")[1].split()[:2]]
    # a flat square grid unwraps to a square filling the UV square (one island)
    assert extent[0] == pytest.approx(extent[1], rel=1e-4) and max(extent) > 0.99


def test_the_manifest_passes_blenders_validator(tmp_path):
    spec = importlib.util.spec_from_file_location("build_extension", ROOT / "scripts" / "build_extension.py")
    be = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(be)

    tool = be.blender_ext()
    stage = be.stage(tmp_path / "stage", [], ROOT / "wheels", ["linux-x64"])
    done = subprocess.run(
        [sys.executable, str(tool), "validate", str(stage), "--valid-tags", str(be.valid_tags(tool))],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0 and "Success" in done.stdout, done.stdout + done.stderr
