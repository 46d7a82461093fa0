"""scripts/batch_unwrap.py on real files, in subprocesses (one Blender per process)."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np

from isoparam_eval import meshes as ex

from .conftest import bpy  # noqa: F401 - skips this module without bpy

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "batch_unwrap.py"


def write_obj(path: Path, V, F):
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in V] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")  # a small test file


def run(*args, cwd=ROOT):
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=600, cwd=cwd
    )
    return done.returncode, done.stdout, done.stderr


def reports(stdout):
    return [json.loads(line) for line in stdout.splitlines() if line.startswith("{")]


def obj_uvs(path: Path):
    return np.array(
        [[float(t) for t in line.split()[1:3]] for line in path.read_text().splitlines() if line.startswith("vt ")]
    )


def test_one_obj_in_one_obj_out(tmp_path):
    V, F, _ = ex.s_surface(20, 6)
    write_obj(tmp_path / "s.obj", V, F)
    code, out, err = run(tmp_path / "s.obj", "-o", tmp_path / "s_uv.obj")
    assert code == 0, err
    [entry] = reports(out)
    assert entry["status"] == "ok" and entry["objects"] == 1
    uv = obj_uvs(tmp_path / "s_uv.obj")
    assert len(uv) > 0 and uv.min() >= 0 and uv.max() <= 1 and np.ptp(uv, axis=0).min() > 0.1
    assert "1/1" in err  # the progress bar


def test_many_files_and_formats_with_a_failure(tmp_path):
    V, F = ex.peaks(11)
    write_obj(tmp_path / "a.obj", V, F)
    write_obj(tmp_path / "b.obj", *ex.s_surface(12, 5)[:2])
    (tmp_path / "bad.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nend_header\n0 0\n")  # broken
    out_dir = tmp_path / "out"
    code, out, err = run(
        tmp_path / "a.obj",
        tmp_path / "bad.ply",
        tmp_path / "b.obj",
        "-o",
        out_dir,
        "--format",
        "glb",
        "--report",
        tmp_path / "report.json",
    )
    assert code == 1  # one file failed
    entries = {Path(e["file"]).name: e for e in reports(out)}
    assert entries["a.obj"]["status"] == "ok" and entries["b.obj"]["status"] == "ok"
    assert entries["bad.ply"]["status"] == "failed" and entries["bad.ply"]["error"]
    assert (out_dir / "a.glb").exists() and (out_dir / "b.glb").exists() and not (out_dir / "bad.glb").exists()
    assert json.loads((tmp_path / "report.json").read_text())[1]["status"] == "failed"
    # the written glTF carries texture coordinates: read it back and unwrap again, to .ply and .blend
    code, out, err = run(out_dir / "a.glb", "-o", tmp_path / "a.ply")
    assert code == 0, err
    code, out, err = run(tmp_path / "a.ply", "-o", tmp_path / "a.blend")
    assert code == 0, err and (tmp_path / "a.blend").exists()


INSIDE_BLENDER = textwrap.dedent(
    """
    # what `blender --background scene.blend --python batch_unwrap.py -- --save` does
    import os, sys, runpy, tempfile
    home = tempfile.TemporaryDirectory()  # removed at exit
    os.environ["BLENDER_USER_RESOURCES"] = home.name
    import bpy
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
    sys.argv = ["blender", "--background", sys.argv[1], "--python", sys.argv[2], "--", "--save"]
    runpy.run_path(sys.argv[4], run_name="__main__")  # exits with the script's status
    """
)


def test_inside_blender_on_the_open_file(tmp_path):
    make = textwrap.dedent(
        f"""
        import os, tempfile, sys
        home = tempfile.TemporaryDirectory()  # removed at exit
        os.environ["BLENDER_USER_RESOURCES"] = home.name
        import bpy
        bpy.ops.wm.read_homefile(use_empty=True)
        bpy.ops.mesh.primitive_monkey_add()
        bpy.ops.mesh.primitive_grid_add(location=(3, 0, 0))
        bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "scene.blend")!r})
        """
    )
    subprocess.run([sys.executable, "-c", make], check=True, capture_output=True)
    done = subprocess.run(
        [sys.executable, "-c", INSIDE_BLENDER, str(tmp_path / "scene.blend"), str(SCRIPT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    [entry] = reports(done.stdout)
    assert entry["objects"] == 2 and entry["output"].endswith("scene.blend")
    check = textwrap.dedent(
        f"""
        import os, tempfile
        home = tempfile.TemporaryDirectory()  # removed at exit
        os.environ["BLENDER_USER_RESOURCES"] = home.name
        import bpy, numpy as np
        bpy.ops.wm.open_mainfile(filepath={str(tmp_path / "scene.blend")!r})
        for ob in bpy.data.objects:
            uv = np.empty(2 * len(ob.data.loops), np.float32)
            ob.data.uv_layers.active.uv.foreach_get("vector", uv)
            print("SPAN", ob.name, float(np.ptp(uv)))
        """
    )
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=600)
    spans = [float(line.split()[-1]) for line in done.stdout.splitlines() if line.startswith("SPAN")]
    assert len(spans) == 2 and min(spans) > 0.5


def test_bad_arguments_exit_with_2(tmp_path):
    code, out, err = run("--no-such-option")
    assert code == 2


def test_extra_cuts_option_reaches_the_operator(tmp_path):
    V, F, _ = ex.box(4)  # closed: cut open automatically, then the extra cuts
    write_obj(tmp_path / "box.obj", V, F)
    counts = {}
    for cuts in ("0", "6"):
        code, out, err = run(
            tmp_path / "box.obj", "-o", tmp_path / f"box_{cuts}.obj", "--extra-cuts", cuts, "--no-charts"
        )
        assert code == 0, err
        # every cut edge splits its vertices' UVs: more cuts, more distinct UVs
        counts[cuts] = len(np.unique(obj_uvs(tmp_path / f"box_{cuts}.obj").round(6), axis=0))
    assert counts["6"] > counts["0"] > len(V)
