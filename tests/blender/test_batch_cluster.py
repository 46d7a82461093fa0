"""scripts/batch_unwrap.py on a Dask cluster (``--scheduler local:N``), outputs written whole
or not at all, and ``--skip-done``: real files, real worker processes."""

import importlib.util
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from isoparam_eval import meshes as ex

from .conftest import bpy  # noqa: F401 - skips this module without bpy
from .test_batch import ROOT, SCRIPT, obj_uvs, reports, run

pytest.importorskip("dask.distributed", reason='the cluster batch needs Dask: pip install "dask[distributed]"')
psutil = pytest.importorskip("psutil")  # (a dependency of dask.distributed)


def _batch_module():
    """scripts/batch_unwrap.py as a module (its helpers, without running it)."""
    spec = importlib.util.spec_from_file_location("batch_unwrap_under_test", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _copies(folder: Path, n: int) -> list[Path]:
    folder.mkdir()
    text = ex.SPOT.read_text()
    paths = [folder / f"spot{k}.obj" for k in range(1, n + 1)]
    for p in paths:
        p.write_text(text)
    return paths


def _partials(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".partial-" in p.name)


def test_a_local_cluster_gives_what_a_local_run_gives_file_for_file(tmp_path):
    # issue 37's bar: 8 copies of spot on 2 workers: exit 0, 8 outputs whose UVs equal a
    # --jobs 1 run's, 8 JSON lines in input order with the same reports
    paths = _copies(tmp_path / "in", 8)
    code, local_out, err = run(*paths, "-o", tmp_path / "local", "--json", "--jobs", "1")
    assert code == 0, err
    code, cluster_out, err = run(*paths, "-o", tmp_path / "cluster", "--json", "--scheduler", "local:2")
    assert code == 0, err
    local, cluster = reports(local_out), reports(cluster_out)
    assert [e["file"] for e in cluster] == [str(p) for p in paths] == [e["file"] for e in local]
    for a, b in zip(local, cluster):
        assert b["status"] == "ok" and Path(b["output"]).parent == tmp_path / "cluster"
        same = {k: v for k, v in a.items() if k not in ("seconds", "output")}
        assert same == {k: v for k, v in b.items() if k not in ("seconds", "output")}
        uv_local, uv_cluster = obj_uvs(Path(a["output"])), obj_uvs(Path(b["output"]))
        assert len(uv_local) > 0 and (uv_local == uv_cluster).all()
    assert not _partials(tmp_path / "cluster")


def test_a_worker_killed_while_it_unwraps_loses_no_file(tmp_path):
    paths = _copies(tmp_path / "in", 8)
    out = tmp_path / "out"
    job = subprocess.Popen(
        [sys.executable, str(SCRIPT), *map(str, paths), "-o", str(out), "--json", "--scheduler", "local:2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        t0 = time.monotonic()
        while not (out.exists() and any(p.suffix == ".obj" and not p.name.startswith(".") for p in out.iterdir())):
            assert job.poll() is None and time.monotonic() - t0 < 300, "the job ended before its first file"
            time.sleep(0.02)
        # the first file is written: both workers are busy with the next ones
        workers = [p for p in psutil.Process(job.pid).children(recursive=True) if "spawn_main" in " ".join(p.cmdline())]
        assert len(workers) == 2
        workers[0].kill()
        stdout, stderr = job.communicate(timeout=600)
    finally:
        if job.poll() is None:
            job.kill()
    assert job.returncode == 0, stderr
    assert "Restarting worker" in stderr  # (the nanny's word: the worker did die mid-job)
    entries = reports(stdout)
    assert [e["status"] for e in entries] == ["ok"] * 8
    expected = obj_uvs(Path(entries[0]["output"]))
    for e in entries:  # every output complete: the same UVs as the first
        assert (obj_uvs(Path(e["output"])) == expected).all()
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in paths)  # and nothing else


def test_skip_done_runs_nothing_on_a_finished_job_and_redoes_what_changed(tmp_path):
    paths = _copies(tmp_path / "in", 2)
    out = tmp_path / "out"
    code, stdout, err = run(*paths, "-o", out, "--json")
    assert code == 0, err
    written = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    code, stdout, err = run(*paths, "-o", out, "--json", "--skip-done")
    assert code == 0, err
    assert [e["status"] for e in reports(stdout)] == ["skipped", "skipped"]
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == written  # nothing was written
    later = time.time() + 5  # an input edited after its output was written is unwrapped again
    os.utime(paths[0], (later, later))
    code, stdout, err = run(*paths, "-o", out, "--json", "--skip-done")
    assert code == 0, err
    redone = [(Path(e["file"]).name, e["status"]) for e in reports(stdout)]
    assert redone == [("spot1.obj", "ok"), ("spot2.obj", "skipped")]
    code, stdout, err = run(*paths, "--in-place", "--skip-done")
    assert code == 2 and "--skip-done cannot tell" in err


def test_an_output_is_written_whole_or_not_at_all(tmp_path):
    batch = _batch_module()
    target = tmp_path / "model.obj"
    target.write_text("the old output\n")
    with pytest.raises(RuntimeError), batch._written(target) as temporary:
        temporary.write_text("half of the new")
        raise RuntimeError("killed while writing")
    assert target.read_text() == "the old output\n" and not _partials(tmp_path)
    with batch._written(target) as temporary:
        assert temporary.parent == target.parent and temporary.suffix == ".obj"  # (the exporter reads it)
        temporary.write_text("the new output\n")
    assert target.read_text() == "the new output\n" and not _partials(tmp_path)
    # a .gltf and the buffer it writes beside itself under its own name move out together
    gltf = tmp_path / "scene.gltf"
    with batch._written(gltf) as temporary:
        assert temporary.name == "scene.gltf"
        temporary.write_text('{"buffers": [{"uri": "scene.bin"}]}')
        (temporary.parent / "scene.bin").write_bytes(b"\0" * 8)
    assert gltf.exists() and (tmp_path / "scene.bin").exists() and not _partials(tmp_path)
    # what a process killed mid-write leaves, the job removes at its end
    (tmp_path / f".model.obj{batch.PARTIAL}123-abcd.obj").write_text("half")
    (tmp_path / f".scene.gltf{batch.PARTIAL}123-abcd").mkdir()
    assert batch.remove_partials([target, gltf]) == 2 and not _partials(tmp_path)


def test_without_dask_the_scheduler_option_says_what_to_install(tmp_path):
    (path,) = _copies(tmp_path / "in", 1)
    hide = (
        "import runpy, sys; sys.modules['dask'] = None; "  # import dask raises ImportError
        f"sys.argv = ['batch_unwrap.py', {str(path)!r}, '-o', {str(tmp_path / 'out')!r}, '--scheduler', 'local:2']; "
        f"runpy.run_path({str(SCRIPT)!r}, run_name='__main__')"
    )
    done = subprocess.run([sys.executable, "-c", hide], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 2
    assert 'pip install "dask[distributed]"' in done.stderr
    assert not (tmp_path / "out").exists()


def test_the_cluster_options_are_checked_before_any_work(tmp_path):
    (path,) = _copies(tmp_path / "in", 1)
    for bad, words in (
        (["--scheduler", "local:0"], "local:N"),
        (["--scheduler", "local:2", "--jobs", "2"], "not both"),
    ):
        code, _, err = run(path, "-o", tmp_path / "out", *bad)
        assert code == 2 and words in err, err
