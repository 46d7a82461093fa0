"""Unwrap many files with Isometric Unwrap, headless.

With Blender as a Python module (``pip install bpy``), on any number of files:

    python scripts/batch_unwrap.py a.obj b.ply c.glb d.blend -o out_dir/ [options]
    python scripts/batch_unwrap.py in.obj -o out.obj --max-stretch 1.1 --json > report.jsonl
    python scripts/batch_unwrap.py models/*.blend --in-place --jobs 2
    python scripts/batch_unwrap.py archive/*.ply -o out/ --scheduler tcp://scheduler:8786 --skip-done

Inside Blender, on the open file (the extension installed):

    blender --background scene.blend --python scripts/batch_unwrap.py -- --in-place [options]

Formats in and out: .obj, .ply, .gltf/.glb, .blend (the output format follows the output
name, or ``--format`` when ``-o`` is a folder). Every mesh object is unwrapped on its own
(``--together`` packs a file's meshes into one UV square), into the active UV map or the
one ``--uv-map`` names; a warning says when that map held UVs already. There must be
somewhere to write: ``-o`` (a file for one input, a folder for several) or ``--in-place``
(each input overwritten; a .blend keeps Blender's ``.blend1`` backup of the original).
Every output is written under a temporary name beside its target and renamed when complete,
so a run that dies leaves no half-written file; ``--skip-done`` skips the inputs whose
output exists and is newer, so a stopped job goes on where it left off.

``--jobs N`` unwraps N files at a time in local processes. ``--scheduler ADDRESS`` makes
every file a task of a Dask cluster (``pip install "dask[distributed]"``; ``local:N`` starts
N worker processes here): each worker imports bpy once and unwraps file after file, a
worker that dies has its file run again elsewhere (``--retries``), and the reports come
back in input order, as with a local run (docs/batch.md).

Every option of the operator's redo panel is a flag (``--help`` lists them). Per file, a
line says what happened: islands, stretch (worst and mean), flipped faces, islands that
overlap themselves, the operator's notes and warnings and the time; ``--json`` prints these as JSON
lines on stdout and sends Blender's log to stderr. Exit status: 0 when every file was
unwrapped (and, with ``--fail-stretch X``, none has a mean stretch above X), 1 otherwise,
2 for bad arguments or a missing extension.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import secrets
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FORMATS = (".obj", ".ply", ".gltf", ".glb", ".blend")
_OWN = ("pack", "pack_shape", "margin", "correct_aspect", "world_scale")  # listed first in --help


class UsageError(Exception):
    """Bad arguments or set-up: the message, and exit status 2."""


def _ensure_addon():
    """The operator from an installed, enabled extension, or from this source tree."""
    import bpy

    if hasattr(bpy.types, "UV_OT_isometric_unwrap"):
        return
    import addon_utils

    for mod in addon_utils.modules():  # installed extensions whose id is isoparam
        if mod.__name__.endswith(".isoparam"):
            addon_utils.enable(mod.__name__, default_set=True)
            if hasattr(bpy.types, "UV_OT_isometric_unwrap"):
                return
    sys.path.insert(0, str(ROOT))
    try:
        import isoparam_addon

        isoparam_addon.register()
    except ImportError as exc:
        raise UsageError(
            f"the Isometric Unwrap extension is not installed in this Blender ({exc}): build its zip with "
            "'bash scripts/build.sh' and install it (Edit > Preferences > Get Extensions > Install from Disk)"
        ) from None


def _ensure_gltf():
    import addon_utils

    if not addon_utils.check("io_scene_gltf2")[1]:
        addon_utils.enable("io_scene_gltf2", default_set=True)


def load(path: Path) -> None:
    import bpy

    ext = path.suffix.lower()
    if ext == ".blend":
        bpy.ops.wm.open_mainfile(filepath=str(path))
        return
    bpy.ops.wm.read_homefile(use_empty=True)
    if ext == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    elif ext == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path))
    elif ext in (".gltf", ".glb"):
        _ensure_gltf()
        bpy.ops.import_scene.gltf(filepath=str(path))
    else:
        raise ValueError(f"cannot read {ext} files (use one of {', '.join(FORMATS)})")


PARTIAL = ".partial-"  # in the names of outputs being written: ``.NAME.partial-TOKEN[.ext]``


def save(path: Path, same_file: bool) -> None:
    """Write the scene to ``path``, whole or not at all (:func:`_written`); ``same_file``: it
    is the open .blend (one save, so Blender's ``.blend1`` keeps the file as it was, and
    Blender writes it under a temporary name itself)."""
    import bpy

    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".blend" and same_file:
        bpy.ops.wm.save_mainfile()
        return
    with _written(path) as temporary:
        _export(temporary)


@contextmanager
def _written(path: Path) -> Iterator[Path]:
    """A temporary path to write ``path`` to, renamed to ``path`` once the block ends well
    (removed if not): a reader, or a job that resumes, never sees a half-written output.
    Beside the target, so that a .blend's relative paths hold; a .gltf, which writes its
    buffers beside itself under its own name, goes to a folder whose files are moved out
    (the .gltf last)."""
    token = f"{path.name}{PARTIAL}{os.getpid()}-{secrets.token_hex(4)}"
    if path.suffix.lower() == ".gltf":
        folder = path.parent / f".{token}"
        folder.mkdir()
        try:
            yield folder / path.name
            for f in sorted(folder.iterdir(), key=lambda f: f.name == path.name):
                os.replace(f, path.parent / f.name)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        return
    temporary = path.parent / f".{token}{path.suffix}"
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def remove_partials(targets) -> int:
    """Remove what writing ``targets`` left half done (a process killed while it wrote);
    how many were removed."""
    gone = 0
    for target in {t for t in targets if t is not None}:
        for left in target.parent.glob(f".{target.name}{PARTIAL}*"):
            shutil.rmtree(left) if left.is_dir() else left.unlink(missing_ok=True)
            gone += 1
    return gone


def _export(path: Path) -> None:
    """Write the scene to ``path`` in the format its extension names."""
    import bpy

    ext = path.suffix.lower()
    if ext == ".blend":
        bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    elif ext == ".obj":
        bpy.ops.wm.obj_export(filepath=str(path), export_uv=True, export_materials=False)
    elif ext == ".ply":
        bpy.ops.wm.ply_export(filepath=str(path), export_uv=True)
    elif ext in (".gltf", ".glb"):
        _ensure_gltf()
        bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB" if ext == ".glb" else "GLTF_SEPARATE")
    else:
        raise ValueError(f"cannot write {ext} files (use one of {', '.join(FORMATS)})")


# ---------------------------------------------------------------------------- one file


def _uv_map(me, name: str | None) -> str | None:
    """Make the UV map to write active (``name``, made if missing; else the active one);
    returns a warning if it holds UVs already."""
    import numpy as np

    layers = me.uv_layers
    if name is not None and name not in layers:
        layers.active = layers.new(name=name)  # (a copy of the active map's UVs, all replaced)
        return None
    if name is not None:
        layers.active = layers[name]
    if layers.active is None:
        return None  # the operator makes one
    uv = np.empty(2 * len(me.loops), dtype=np.float32)
    layers.active.uv.foreach_get("vector", uv)
    if len(uv) and np.ptp(uv) > 0:
        return f"'{me.name}': replaced the UVs of its UV map '{layers.active.name}'"
    return None


def _measure(meshes) -> dict:
    """Islands, stretch (worst, mean), flipped faces, self-overlapping islands and the
    coverage of the UV square (all meshes together) of the active UV maps of ``meshes``
    (object mode)."""
    import numpy as np

    from isoparam_addon.blender import mesh_io
    from isoparam_addon.solver import metrics

    islands = flips = overlapping = 0
    parts, layouts = [], []
    for ob in meshes:
        sel = mesh_io.read_selection(ob, world_space=False, uv_selection_locks=False, every_face=True)
        cuv = sel.uv[sel.tri_loops].astype(np.float64)
        label = metrics.uv_islands(sel.F, cuv)
        per = metrics.per_island(sel.V, sel.F, cuv, label)
        islands += per.n_islands
        flips += int(per.flipped.sum())
        overlapping += metrics.self_overlaps(sel.V, sel.F, cuv, label).islands
        parts.append(metrics.face_stretch(sel.V, sel.F, cuv)[1])
        layouts.append(cuv)
    worst, mean, _ = metrics.combine_stretch(parts)
    return dict(
        islands=islands,
        stretch_worst=round(worst, 4),
        stretch_mean=round(mean, 4),
        flipped=flips,
        overlapping=overlapping,
        coverage=round(metrics.coverage(*layouts), 4),
    )


def unwrap_scene(args, operator: dict) -> dict:
    """Unwrap the mesh objects of the current scene with the operator's ``operator``
    options; returns the file's report (without its status)."""
    import bpy

    meshes = [ob for ob in bpy.context.scene.objects if ob.type == "MESH" and len(ob.data.polygons)]
    if args.objects:
        meshes = [ob for ob in meshes if ob.name in args.objects]
    if not meshes:
        raise RuntimeError("no mesh objects to unwrap")
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    warnings = [w for w in (_uv_map(ob.data, args.uv_map) for ob in meshes) if w]
    notes = []
    groups = [meshes] if args.together else [[ob] for ob in meshes]
    for group in groups:  # one operator call per object (or one for all)
        for ob in bpy.context.scene.objects:
            ob.select_set(ob in group)
        bpy.context.view_layer.objects.active = group[0]
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.reveal()
        bpy.ops.mesh.select_all(action="SELECT")
        try:
            bpy.ops.uv.isometric_unwrap(**operator)
        finally:
            bpy.ops.object.mode_set(mode="OBJECT")
        # (the operator's record, as JSON: this script may run an installed extension,
        # whose modules are not isoparam_addon's)
        run = json.loads(bpy.context.window_manager.isoparam_run_record)
        notes += run["notes"]
        warnings += run["warnings"]
    return dict(
        objects=len(meshes),
        faces=sum(len(ob.data.polygons) for ob in meshes),
        **_measure(meshes),
        notes=notes,
        warnings=warnings,
    )


def run_file(args, operator: dict, path: Path | None, target: Path | None) -> dict:
    """Load, unwrap and save one file (``path`` None: the open .blend); its report."""
    import bpy

    t0 = time.perf_counter()
    entry: dict = {"file": str(path or bpy.data.filepath)}
    try:
        if path is not None:
            load(path)
        entry.update(unwrap_scene(args, operator))
        if target is not None:
            same = target.suffix.lower() == ".blend" and Path(bpy.data.filepath or "").resolve() == target.resolve()
            save(target, same)
            entry["output"] = str(target)
        entry["status"] = "ok"
        if args.fail_stretch is not None and entry["stretch_mean"] > args.fail_stretch:
            entry["status"] = "too stretched"
    except Exception as exc:  # report and go on with the next file
        entry.update(status="failed", error=(str(exc).strip().splitlines() or [type(exc).__name__])[-1][:500])
    entry["seconds"] = round(time.perf_counter() - t0, 3)
    return entry


# ---------------------------------------------------------------------------- arguments


def _operator_flags(ap: argparse.ArgumentParser) -> list[str]:
    """A flag per property of the operator (read from its RNA, so none is missing); their
    names (the operator's keywords)."""
    import bpy

    group = ap.add_argument_group("unwrap options (the operator's redo panel; default: the operator's)")
    props = [p for p in bpy.ops.uv.isometric_unwrap.get_rna_type().properties if p.identifier != "rna_type"]
    props.sort(key=lambda p: (p.identifier not in _OWN, _OWN.index(p.identifier) if p.identifier in _OWN else 0))
    names = []
    for p in props:
        flag = "--" + p.identifier.replace("_", "-")
        default = f"{p.default:.4g}" if p.type == "FLOAT" else p.default
        text = f"{p.name}: {p.description} (default: {default})"
        text = text.replace("%", "%%")
        if p.type == "BOOLEAN":
            group.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, help=text)
        elif p.type == "ENUM":
            group.add_argument(flag, choices=[item.identifier for item in p.enum_items], default=None, help=text)
        elif p.type == "INT":
            group.add_argument(flag, type=int, default=None, help=text)
        elif p.type == "FLOAT":
            group.add_argument(flag, type=float, default=None, help=text)
        else:  # pragma: no cover - the operator has no other kinds of properties
            continue
        names.append(p.identifier)
    return names


def parse(argv):
    ap = argparse.ArgumentParser(
        prog="batch_unwrap", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("inputs", nargs="*", type=Path, help="files to unwrap (none: the open .blend, inside Blender)")
    ap.add_argument("-o", "--out", type=Path, help="output file (one input) or folder (several inputs)")
    ap.add_argument("--format", choices=[f[1:] for f in FORMATS], help="output format when --out is a folder")
    ap.add_argument("--in-place", action="store_true", help="overwrite each input (a .blend keeps its .blend1 backup)")
    ap.add_argument("--save", action="store_true", help=argparse.SUPPRESS)  # the former name of --in-place
    ap.add_argument("--objects", nargs="+", help="only these objects")
    ap.add_argument("--together", action="store_true", help="pack all meshes of a file into one UV square")
    ap.add_argument("--uv-map", help="the UV map to write (made if missing; default: the active one)")
    ap.add_argument("--fail-stretch", type=float, help="exit 1 when a file's mean stretch is above this")
    ap.add_argument("--json", action="store_true", help="JSON lines on stdout; Blender's log on stderr")
    ap.add_argument("--jobs", type=int, default=1, help="files unwrapped in parallel processes (bpy module only)")
    ap.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="unwrap on a Dask cluster: its scheduler's address, or local:N for N worker processes here "
        '(pip install "dask[distributed]")',
    )
    ap.add_argument(
        "--retries", type=int, default=2, help="with --scheduler: times a file is run again when its worker dies"
    )
    ap.add_argument("--skip-done", action="store_true", help="skip inputs whose output exists and is newer")
    ap.add_argument("--report", type=Path, help="also write every file's report into one JSON file")
    names = _operator_flags(ap)
    args = ap.parse_args(argv)
    args.in_place |= args.save
    operator = {k: getattr(args, k) for k in names if getattr(args, k) is not None}
    return args, operator


def outputs(args, paths: list[Path | None]) -> list[Path | None]:
    """Where each input goes; raises :class:`UsageError` when there is nowhere, or no single file
    can take several inputs."""
    import bpy

    if args.out is not None and args.in_place:
        raise UsageError("give -o or --in-place, not both")
    if args.out is None:
        if not args.in_place:
            raise UsageError(
                "nothing would be written: give -o (a file or folder), or --in-place to overwrite the inputs"
            )
        return [p if p is not None else Path(bpy.data.filepath) for p in paths]
    folder = len(paths) > 1 or args.out.suffix.lower() not in FORMATS or args.out.is_dir()
    if len(paths) > 1 and args.out.suffix.lower() in FORMATS:
        raise UsageError(f"-o {args.out} names one file, but there are {len(paths)} inputs: give a folder")
    if not folder:
        return [args.out]
    out = []
    for p in paths:
        fmt = "." + (args.format or (p.suffix.lstrip(".") if p else "blend"))
        out.append(args.out / f"{p.stem if p else Path(bpy.data.filepath).stem}{fmt}")
    if len(set(out)) < len(out):
        raise UsageError("two inputs would be written to the same output name: unwrap them into separate folders")
    return out


# ---------------------------------------------------------------------------- output


class Progress:
    """One line on stderr, redrawn in place: ``[####......] 3/8 name: status``."""

    def __init__(self, total: int):
        self.total, self.done = total, 0

    def show(self, name: str, status: str) -> None:
        width = 24
        filled = int(width * self.done / max(self.total, 1))
        line = f"[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} {name}: {status}"
        sys.stderr.write("\r" + line[:119].ljust(119))
        sys.stderr.flush()

    def close(self) -> None:
        sys.stderr.write("\n")


def describe(entry: dict) -> str:
    """One line per file."""
    name = Path(entry["file"]).name
    if entry["status"] == "skipped":
        return f"{name}: skipped, its output is newer -> {entry['output']}"
    if entry["status"] == "failed":
        return f"{name}: FAILED: {entry['error']} ({entry['seconds']:.2f} s)"
    text = (
        f"{name}: {entry['status']}, {entry['islands']} islands, stretch worst {entry['stretch_worst']:.3g} "
        f"mean {entry['stretch_mean']:.4g}, coverage {entry['coverage']:.0%}, {entry['flipped']} flipped, "
        f"{entry['overlapping']} overlapping, "
        f"{entry['seconds']:.2f} s" + (f" -> {entry['output']}" if "output" in entry else "")
    )
    notes = "".join(f"\n    note: {n}" for n in entry.get("notes", []))
    return text + notes + "".join(f"\n    warning: {w}" for w in entry["warnings"])


def _child_argv(argv: list[str], inputs: list[Path]) -> list[str]:
    """``argv`` without the inputs and the options the parent handles (output, jobs,
    report, JSON): what every per-file child process is given besides its file."""
    own = {"-o", "--out", "--format", "--jobs", "--report", "--scheduler", "--retries"}  # (with a value)
    flags = {"--json", "--in-place", "--save", "--skip-done"}
    names = {str(p) for p in inputs}
    out, skip = [], False
    for token in argv:
        if skip:
            skip = False
        elif token in own:
            skip = True
        elif token in flags or token in names or any(token.startswith(f"{o}=") for o in own):
            continue
        else:
            out.append(token)
    return out


_BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _in_children(argv, args, paths, targets, progress: Progress, emit) -> list[dict]:
    """Each file in its own process, ``args.jobs`` at a time; reports in input order."""
    rest = _child_argv(argv, paths)
    # one BLAS thread per process: N processes of two threads each on N cores fight for
    # them (the 8 shared meshes, --jobs 2 on 2 cores: 27.4 s with the default, 18.1 s so)
    env = {**os.environ}
    for name in _BLAS_THREADS:
        env.setdefault(name, "1")

    def one(k: int) -> dict:
        cmd = [sys.executable, __file__, str(paths[k]), "-o", str(targets[k]), "--json", *rest]
        done = subprocess.run(cmd, capture_output=True, text=True, env=env)
        lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
        if lines:
            return json.loads(lines[-1])
        error = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
        return {"file": str(paths[k]), "status": "failed", "error": error[:500], "seconds": 0.0}

    entries: list[dict | None] = [None] * len(paths)
    with ThreadPoolExecutor(args.jobs) as pool:
        futures = {pool.submit(one, k): k for k in range(len(paths))}
        for future in futures:  # (input order; each waits for its own)
            k = futures[future]
            entries[k] = future.result()
            progress.done += 1
            progress.show(paths[k].name, entries[k]["status"])
            emit(entries[k])
    return [e for e in entries if e is not None]


# ---------------------------------------------------------------------------- on a cluster

_BPY = threading.Lock()  # one file at a time per process: bpy is not thread-safe


def unwrap_remote(path: str, target: str, argv: list[str]) -> dict:
    """One file on a Dask worker (its task): bpy and the add-on are imported once per
    worker process, each file gets a fresh scene (:func:`load`), and the report is the one
    a local run gives (:func:`run_file`)."""
    with _BPY:
        if "bpy" not in sys.modules:  # (the first file of this worker process)
            _keep_freed_memory()
            # a worker spawned here inherits the client's sys.path, which importing bpy
            # extended with Blender's script folders inside the bpy package, where a
            # package named bpy would shadow the module: bpy puts them back itself
            inside = f"{os.sep}bpy{os.sep}"
            sys.path[:] = [p for p in sys.path if inside not in p]
        _ensure_addon()
        args, operator = parse([path, *argv])
        return run_file(args, operator, Path(path), Path(target))


def _keep_freed_memory() -> None:
    """Let glibc keep freed memory for the next allocation, as it does by default. Dask's
    nanny starts workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (to hand memory back to the
    system), which fixes glibc's thresholds so low that every large numpy array is mapped
    and unmapped afresh: the solver then takes twice as long (bunny, charts on: 7.1 s, 14.8
    s under that setting). Elsewhere than glibc, nothing to do."""
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return
    m_trim_threshold, m_mmap_threshold = -1, -3  # (malloc.h)
    libc.mallopt(m_trim_threshold, 256 << 20)
    libc.mallopt(m_mmap_threshold, 32 << 20)


def _dask():
    """``dask.distributed``, or a :class:`UsageError` that names the package to install."""
    try:
        import dask
        import dask.distributed
    except ImportError:
        raise UsageError(
            '--scheduler needs Dask, an optional extra of the batch job: pip install "dask[distributed]"'
        ) from None
    return dask


def _local_workers(address: str) -> int:
    """N for ``local:N`` (N >= 1, else a :class:`UsageError`), 0 for a scheduler's address."""
    if not address.startswith("local:"):
        return 0
    n = address.split(":", 1)[1]
    if not n.isdigit() or int(n) < 1:
        raise UsageError(f"--scheduler {address}: give local:N with N >= 1 worker processes")
    return int(n)


@contextmanager
def _client(address: str, retries: int):
    """A Dask client of the cluster at ``address`` (``local:N``: N worker processes on this
    machine, one thread each, started and stopped here), with this script on its workers."""
    dask = _dask()
    from dask.distributed import Client, LocalCluster

    # a task whose worker dies is run again elsewhere, up to this many times (with a
    # remote scheduler, its own setting counts)
    # (the workers' statistical profiler samples every 10 ms: a tenth of the time of a solve)
    settings = {"distributed.scheduler.allowed-failures": retries, "distributed.worker.profile.enabled": False}
    with dask.config.set(settings):
        n = _local_workers(address)
        if n:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
        else:
            cluster = None
            try:
                client = Client(address, timeout=30)
            except OSError as exc:
                raise UsageError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
        try:
            client.upload_file(__file__)  # (workers elsewhere have no copy of this script)
            yield client
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


def _on_cluster(argv, args, paths, targets, progress: Progress, emit) -> list[dict]:
    """Each file a task of the Dask cluster ``args.scheduler``; reports in input order, each
    as soon as it and the ones before it are done."""
    rest = _child_argv(argv, paths)
    with _client(args.scheduler, args.retries) as client:
        import batch_unwrap as this  # (by name, so that the workers import it, not a copy of __main__)

        futures = [
            client.submit(this.unwrap_remote, str(p), str(t), rest, pure=False, retries=args.retries)
            for p, t in zip(paths, targets)
        ]
        entries = []
        for path, future in zip(paths, futures):
            try:
                entry = future.result()
            except Exception as exc:  # the file's every try died with its worker
                why = f"{type(exc).__name__}: {exc}".strip().splitlines()[0][:500]
                entry = {"file": str(path), "status": "failed", "error": why, "seconds": 0.0}
            entries.append(entry)
            progress.done += 1
            progress.show(path.name, entry["status"])
            emit(entry)
    remove_partials(targets)  # of workers killed while they wrote
    return entries


def _done(paths, targets) -> list[bool]:
    """Per input: its output exists and is newer than it (``--skip-done``)."""
    return [
        p is not None and t is not None and t.exists() and t.stat().st_mtime > p.stat().st_mtime
        for p, t in zip(paths, targets)
    ]


def main(argv=None) -> int:
    """Unwrap the files the command line names (:func:`parse`); the exit status."""
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    real_stdout = _stdout_for(argv)
    try:
        args, operator, paths, targets = _set_up(argv)
        emit = _printer(args, real_stdout)
        report = _run_all(argv, args, operator, paths, targets, emit)
    except UsageError as exc:
        print(f"batch_unwrap: {exc}", file=sys.stderr)
        return 2
    return _summarize(args, report)


def _stdout_for(argv: list[str]):
    """Where reports go: stdout, or with ``--json`` the real stdout, Blender's log sent to stderr."""
    if "--json" not in argv:
        return sys.stdout
    real_stdout = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return real_stdout


def _set_up(argv: list[str]):
    """Parse and check the arguments: (args, operator options, inputs, outputs), or a UsageError."""
    import bpy

    _ensure_addon()
    args, operator = parse(argv)
    if (args.jobs > 1 or args.scheduler) and bpy.app.binary_path:
        raise UsageError(
            "--jobs and --scheduler run Blender as a Python module (pip install bpy), not inside a Blender binary"
        )
    if args.jobs > 1 and args.scheduler:
        raise UsageError("give --jobs or --scheduler, not both")
    if args.skip_done and args.in_place:
        raise UsageError("--skip-done cannot tell a finished file when the output is the input (--in-place)")
    paths: list[Path | None] = list(args.inputs)
    if not paths:
        if not bpy.data.filepath:
            raise UsageError("no input files, and no .blend is open")
        if args.scheduler:
            raise UsageError("--scheduler unwraps files given as inputs, not the open .blend")
        paths = [None]  # the file Blender opened
    targets = outputs(args, paths)
    if args.scheduler:  # (before any work)
        _local_workers(args.scheduler)
        _dask()
    return args, operator, paths, targets


def _printer(args, real_stdout):
    """A function that prints one file's report: a JSON line (``--json``) or :func:`describe`'s lines."""

    def emit(entry: dict) -> None:
        if args.json:
            real_stdout.write(json.dumps(entry) + "\n")
            real_stdout.flush()
        else:
            sys.stderr.write("\r" + " " * 119 + "\r")
            print(describe(entry), flush=True)

    return emit


def _left_to_run(args, paths, targets) -> tuple[list[int], list[tuple[int, dict]]]:
    """The inputs to run (their indices), and the (index, report) of those ``--skip-done`` skips."""
    if not args.skip_done:
        return list(range(len(paths))), []
    done = _done(paths, targets)
    skipped = [
        (k, {"file": str(p), "status": "skipped", "output": str(t), "seconds": 0.0})
        for k, (p, t, d) in enumerate(zip(paths, targets, done))
        if d
    ]
    return [k for k, d in enumerate(done) if not d], skipped


def _run_all(argv, args, operator: dict, paths, targets, emit) -> list[dict]:
    """Unwrap the inputs (cluster, child processes or here); every report, emitted in input order."""
    progress = Progress(len(paths))
    report: list[dict] = []
    left, skipped = _left_to_run(args, paths, targets)  # skipped: emitted in their place
    paths, targets = [paths[k] for k in left], [targets[k] for k in left]

    def emit_next(entry: dict | None) -> None:
        """Emit ``entry`` (the next file run, or None at the end) after the skipped ones before it."""
        ran = sum(e["status"] != "skipped" for e in report)
        while skipped and (entry is None or skipped[0][0] < left[ran]):
            _, s_entry = skipped.pop(0)
            progress.done += 1
            emit(s_entry)
            report.append(s_entry)
        if entry is not None:
            emit(entry)
            report.append(entry)

    if args.scheduler and paths:
        _on_cluster(argv, args, paths, targets, progress, emit_next)
    elif args.jobs > 1 and len(paths) > 1:
        _in_children(argv, args, [p for p in paths if p is not None], targets, progress, emit_next)
    else:
        _one_at_a_time(args, operator, paths, targets, progress, emit_next)
    emit_next(None)
    progress.close()
    return report


def _one_at_a_time(args, operator: dict, paths, targets, progress: Progress, emit) -> list[dict]:
    """Each file in this process, one after the other (a None path: the open .blend)."""
    import bpy

    entries = []
    for path, target in zip(paths, targets):
        name = path.name if path else Path(bpy.data.filepath).name
        progress.show(name, "unwrapping")
        entry = run_file(args, operator, path, target)
        progress.done += 1
        progress.show(name, entry["status"])
        emit(entry)
        entries.append(entry)
    return entries


def _summarize(args, report: list[dict]) -> int:
    """Write ``--report`` and say how many files were unwrapped; the exit status."""
    if args.report:
        args.report.write_text(json.dumps(report, indent=1))
    bad = [e for e in report if e["status"] not in ("ok", "skipped")]
    print(f"batch_unwrap: {len(report) - len(bad)} of {len(report)} files unwrapped", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    code = main()
    import bpy

    if not bpy.app.binary_path and bpy.app.version < (4, 3, 0):
        # bpy 4.2 as a Python module segfaults in its teardown after several glTF
        # exports (measured with 4.2.23); everything is written, so leave at once
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
