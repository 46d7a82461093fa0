"""Where a solve spends its time, stage by stage: the progress reports, timed.

``parametrize`` reports each stage as it starts (``progress=``); the time from one report
to the next is the stage's. Per stage name (topology, the four steps, refinement,
placement, and the charting rounds, overlap and extra cuts they run in) the table gives
seconds, share and calls, summed over every solve of the run, then the same per round
(charting, its rounds, the overlap cuts), then every refinement the run made: its
descent iterations (and local/global steps), the islands it refined and its seconds.
With ``--operator`` the mesh goes through Blender's operator end to end (reading, the
solve, writing, the pack) instead of the solver alone with the operator's options.

    python scripts/profile.py ../shared/meshes/stanford-bunny.obj
    python scripts/profile.py model.obj --seams smart --operator
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import parametrize
from isoparam_eval.corpus import load_mesh

OPERATOR = DEFAULTS.solver_options()  # the solver's options as the operator's defaults ask for them


class StageClock:
    """A ``progress`` callback that charges the time from each report to the next to the
    stage the first one named."""

    def __init__(self):
        self.seconds: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self.stage, self.at = "start", time.perf_counter()

    def __call__(self, fraction: float, stage: str) -> None:
        now = time.perf_counter()
        self.seconds[self.stage] += now - self.at
        self.calls[stage] += 1
        self.stage, self.at = stage, now

    def table(self, key) -> list[tuple[str, float, int]]:
        """(name, seconds, calls) per ``key(stage)``, most seconds first."""
        seconds: dict[str, float] = defaultdict(float)
        calls: dict[str, int] = defaultdict(int)
        for stage, s in self.seconds.items():
            seconds[key(stage)] += s
            calls[key(stage)] += self.calls[stage]
        return sorted(((k, s, calls[k]) for k, s in seconds.items()), key=lambda r: -r[1])


STEPS = ("topology", "local flattening", "weights", "embedding", "alignment", "refinement", "placement")


def _step(stage: str) -> str:
    """The step of one solve, a stage of its own outside the solves (charting's choices),
    or what runs between the solves of a round (cuts, graphs, checks)."""
    parts = stage.split(", ")
    if stage == "start":
        return "before the solve (reading, set-up)"
    if parts[-1] in STEPS or len(parts) == 1:
        return parts[-1]
    return "between solves (cuts, graphs, checks)"


def _round(stage: str) -> str:
    """The round a stage belongs to: charting's first solve, a charting round, the overlap
    or extra cuts, or the work between their solves."""
    parts = stage.split(", ")
    if parts[-1] in STEPS:
        return ", ".join(parts[:-1]) or "the solve"
    return stage if stage in ("start", "done") else f"{stage} (between solves)"


def _print(title: str, rows, total: float) -> None:
    print(f"\n| {title} | seconds | share | reports |\n|---|---|---|---|")
    for name, s, calls in rows:
        print(f"| {name} | {s:.3f} | {100 * s / total:.1f}% | {calls} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", type=Path, help="OBJ, OFF, PLY or STL")
    ap.add_argument("--seams", choices=["none", "smart"], default="none", help="Smart UV Project's islands as seams")
    ap.add_argument("--operator", action="store_true", help="through Blender's operator (bpy), end to end")
    args = ap.parse_args(argv)
    V, F = load_mesh(args.mesh)
    seams = None
    if args.seams == "smart" or args.operator:
        from isoparam_eval.blender import smart_uv_seams

        seams = smart_uv_seams(V, F) if args.seams == "smart" else None
    clock = StageClock()
    refinements = _watch_refinements()
    t0 = time.perf_counter()
    if args.operator:
        record = _through_operator(V, F, seams, clock)
    else:
        result = parametrize(V, F, seams, options=OPERATOR, progress=clock)
    total = time.perf_counter() - t0
    print(f"{args.mesh.name}: {len(V):,} vertices, {len(F):,} faces, seams {args.seams}: {total:.2f} s")
    if args.operator:
        print(
            f"operator: read {record.read:.3f} s, solve {record.solve:.3f} s, write {record.write:.3f} s, "
            f"pack {record.pack:.3f} s, total {record.total:.3f} s"
        )
    else:
        print(
            f"solver: {result.n_islands} islands, {result.stats.chart_rounds} charting rounds, "
            f"{result.stats.refine_iterations} refinement iterations"
        )
    solve = sum(s for _, s, _ in clock.table(_step))
    _print("step (every solve)", clock.table(_step), solve)
    _print("round", clock.table(_round), solve)
    print("\n| refinement | iterations | local/global steps | islands | seconds |\n|---|---|---|---|---|")
    for k, (it, steps, islands, seconds) in enumerate(refinements, 1):
        print(f"| {k} | {it} | {steps} | {islands} | {seconds:.3f} |")
    print(
        f"| all | {sum(r[0] for r in refinements)} | {sum(r[1] for r in refinements)} | | "
        f"{sum(r[3] for r in refinements):.3f} |"
    )
    return 0


def _watch_refinements() -> list[tuple[int, int, int, float]]:
    """A list that every call of the refinement (by :func:`.pipeline.solve`) adds its
    iterations, local/global steps, islands and seconds to (hand-overs count in their
    caller's)."""
    from isoparam_addon.solver import pipeline

    calls: list[tuple[int, int, int, float]] = []
    inner = pipeline.refine

    def refine(X, faces, uv, islands, *args, **kwargs):
        out = inner(X, faces, uv, islands, *args, **kwargs)
        calls.append((out.iterations, out.arap_iterations, islands.n, out.seconds))
        return out

    pipeline.refine = refine
    return calls


def _through_operator(V, F, seams, clock: StageClock):
    """The operator's run with the solver's stages timed (its ``Unwrap`` reports progress
    through :meth:`~isoparam_addon.blender.unwrap.Unwrap.progressed`)."""
    import isoparam_addon
    from isoparam_addon.blender import unwrap
    from isoparam_addon.blender.record import last_record
    from isoparam_eval.blender import add_mesh, bpy, edit

    class Timed(unwrap.Unwrap):
        def progressed(self, fraction, stage):
            clock(fraction, stage)
            return super().progressed(fraction, stage)

    isoparam_addon.register()
    unwrap.Unwrap = Timed  # (the operator builds its run from the module's class)
    ob = add_mesh("m", V, F, seams)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    return last_record(bpy.context)


if __name__ == "__main__":
    raise SystemExit(main())
