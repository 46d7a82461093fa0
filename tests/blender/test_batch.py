"""scripts/batch_unwrap.py on real files, in subprocesses (one Blender per process)."""

import json
import os
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
    assert "s.obj: ok, 1 islands, stretch worst" in out  # a line per file
    uv = obj_uvs(tmp_path / "s_uv.obj")
    assert len(uv) > 0 and uv.min() >= 0 and uv.max() <= 1 and np.ptp(uv, axis=0).min() > 0.1
    assert "1/1 s.obj: ok" in err  # the progress bar (redrawn in place with \\r)
    # --json: JSON lines on stdout, nothing else there (Blender's log goes to stderr)
    code, out, err = run(tmp_path / "s.obj", "-o", tmp_path / "s_uv2.obj", "--json")
    assert code == 0, err
    [entry] = [json.loads(line) for line in out.splitlines()]
    assert entry["status"] == "ok" and entry["objects"] == 1 and entry["islands"] == 1
    assert entry["stretch_worst"] >= entry["stretch_mean"] >= 1.0 and entry["flipped"] == 0
    assert entry["overlapping"] == 0 and entry["warnings"] == [] and entry["seconds"] > 0
    assert 0.1 < entry["coverage"] <= 1.0  # the share of the UV square the faces cover


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
        "--json",
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
    # what `blender --background scene.blend --python batch_unwrap.py -- --in-place --json` does
    import os, sys, runpy, tempfile
    home = tempfile.TemporaryDirectory()  # removed at exit
    os.environ["BLENDER_USER_RESOURCES"] = home.name
    import bpy
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
    sys.argv = ["blender", "--background", sys.argv[1], "--python", sys.argv[2], "--", "--in-place", "--json"]
    runpy.run_path(sys.argv[4], run_name="__main__")  # exits with the script's status
    """
)


def _blender(code: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh bpy process with a throw-away user folder."""
    head = textwrap.dedent(
        """
        import os, tempfile
        home = tempfile.TemporaryDirectory()  # removed at exit
        os.environ["BLENDER_USER_RESOURCES"] = home.name
        import bpy, numpy as np
        """
    )
    return subprocess.run([sys.executable, "-c", head + textwrap.dedent(code)], capture_output=True, text=True)


def _spans(path: Path) -> list[float]:
    """The extent of every object's active UV map in a .blend."""
    done = _blender(
        f"""
        bpy.ops.wm.open_mainfile(filepath={str(path)!r})
        for ob in sorted(bpy.data.objects, key=lambda o: o.name):
            uv = np.empty(2 * len(ob.data.loops), np.float32)
            ob.data.uv_layers.active.uv.foreach_get("vector", uv)
            print("SPAN", float(np.ptp(uv)))
        """
    )
    return [float(line.split()[-1]) for line in done.stdout.splitlines() if line.startswith("SPAN")]


def test_inside_blender_on_the_open_file_keeps_the_backup(tmp_path):
    # a scene whose UVs are all one point; unwrapped in place, saved once: the .blend1 holds it as it was
    scene = tmp_path / "scene.blend"
    _blender(
        f"""
        bpy.ops.wm.read_homefile(use_empty=True)
        bpy.ops.mesh.primitive_monkey_add()
        bpy.ops.mesh.primitive_grid_add(location=(3, 0, 0))
        for ob in bpy.data.objects:
            ob.data.uv_layers.active.uv.foreach_set("vector", np.full(2 * len(ob.data.loops), 0.25, np.float32))
        bpy.ops.wm.save_as_mainfile(filepath={str(scene)!r})
        """
    ).check_returncode()
    assert _spans(scene) == [0.0, 0.0]
    done = subprocess.run(
        [sys.executable, "-c", INSIDE_BLENDER, str(scene), str(SCRIPT)], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout + done.stderr
    [entry] = reports(done.stdout)
    assert entry["objects"] == 2 and entry["output"].endswith("scene.blend")
    assert min(_spans(scene)) > 0.5
    assert _spans(tmp_path / "scene.blend1") == [0.0, 0.0]


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


def test_the_line_per_file_gives_the_operators_notes(tmp_path):
    V, F, _ = ex.box(4)  # closed: cut into charts, which the operator notes
    write_obj(tmp_path / "box.obj", V, F)
    code, out, err = run(tmp_path / "box.obj", "-o", tmp_path / "box_uv.obj")
    assert code == 0, err
    assert "\n    note: 'box" in out and "charts" in out


def test_nothing_to_write_is_an_error(tmp_path):
    write_obj(tmp_path / "a.obj", *ex.peaks(7))
    write_obj(tmp_path / "b.obj", *ex.peaks(8))
    code, out, err = run(tmp_path / "a.obj")
    assert code == 2 and "nothing would be written" in err
    code, out, err = run(tmp_path / "a.obj", tmp_path / "b.obj", "-o", tmp_path / "both.obj")
    assert code == 2 and "names one file, but there are 2 inputs" in err
    assert not (tmp_path / "both.obj").exists()
    # --in-place overwrites the input (an .obj has no backup)
    code, out, err = run(tmp_path / "a.obj", "--in-place")
    assert code == 0, err
    assert len(obj_uvs(tmp_path / "a.obj")) > 0


def test_uv_map_fail_stretch_and_warnings(tmp_path):
    write_obj(tmp_path / "p.obj", *ex.peaks(15))
    code, out, err = run(tmp_path / "p.obj", "-o", tmp_path / "p.blend", "--json")
    assert code == 0, err
    # again, into the map it wrote: the report warns that its UVs were replaced
    code, out, err = run(tmp_path / "p.blend", "-o", tmp_path / "q.blend", "--json", "--uv-map", "UVMap")
    [entry] = reports(out)
    assert code == 0 and any("replaced the UVs of its UV map 'UVMap'" in w for w in entry["warnings"])
    # a new map, named: no warning, and the old one is kept
    code, out, err = run(tmp_path / "p.blend", "-o", tmp_path / "r.blend", "--json", "--uv-map", "iso")
    [entry] = reports(out)
    assert code == 0 and not [w for w in entry["warnings"] if "replaced" in w]
    names = _blender(
        f"""
        bpy.ops.wm.open_mainfile(filepath={str(tmp_path / "r.blend")!r})
        print("MAPS", [m.name for m in bpy.data.objects[0].data.uv_layers])
        """
    ).stdout
    assert "MAPS ['UVMap', 'iso']" in names
    # a quality gate: the peaks stretch more than 1.01 on average, so the file fails it
    code, out, err = run(tmp_path / "p.obj", "-o", tmp_path / "s.obj", "--json", "--fail-stretch", "1.01")
    [entry] = reports(out)
    assert code == 1 and entry["status"] == "too stretched" and entry["stretch_mean"] > 1.01


def test_jobs_give_the_same_files(tmp_path):
    inputs = []
    for k, make in enumerate([lambda: ex.peaks(9), lambda: ex.peaks(12), lambda: ex.s_surface(12, 5)[:2], ex.box]):
        V, F = make()[:2]
        write_obj(tmp_path / f"m{k}.obj", V, F)
        inputs.append(tmp_path / f"m{k}.obj")
    for jobs in ("1", "2"):
        code, out, err = run(*inputs, "-o", tmp_path / f"out{jobs}", "--jobs", jobs, "--json")
        assert code == 0, err
        assert [Path(e["file"]).name for e in reports(out)] == [p.name for p in inputs]
    for p in inputs:
        assert np.array_equal(obj_uvs(tmp_path / "out1" / p.name), obj_uvs(tmp_path / "out2" / p.name))


def test_a_blender_without_the_extension_says_so(tmp_path):
    # scipy missing, as in a Blender without the extension (which bundles it)
    (tmp_path / "scipy").mkdir()
    (tmp_path / "scipy" / "__init__.py").write_text("raise ImportError('No module named scipy')\n")
    write_obj(tmp_path / "a.obj", *ex.peaks(7))
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(tmp_path / "a.obj"), "-o", str(tmp_path / "b.obj")],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(tmp_path)},
        timeout=600,
    )
    assert done.returncode == 2 and "extension is not installed" in done.stderr, done.stderr
