"""Progress and cancel (solver/progress.py): a long solve says how far it is and in which
stage, and stops at once, with nothing changed, when its caller asks."""

import time

import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import Cancelled, parametrize, progress
from isoparam_eval import meshes as ex

REFINE = DEFAULTS.refine  # the operator's

CASES = {  # a mesh and options that take each path of a solve (charts, overlap cuts, extra cuts)
    "spot, charts": (lambda: ex.load_obj(ex.SPOT)[:2], dict(charts=True, refine=REFINE, split_overlaps=True)),
    "peaks, charts checked": (lambda: ex.peaks(41, z_scale=2.0), dict(charts=True, refine=REFINE, split_overlaps=True)),
    "ribbon, overlap cuts": (ex.helical_ribbon, dict(charts=False, refine=REFINE, split_overlaps=True)),
    "box, extra cuts": (lambda: ex.box(6)[:2], dict(charts=False, refine=REFINE, extra_cuts=DEFAULTS.extra_cuts)),
    "sphere band, refinement 0": (ex.sphere_band, dict(charts=False, refine=0, unfold=True)),
}
ONE_OF_EACH_PATH = {  # a stage each case must pass through
    "spot, charts": "placing cuts",
    "peaks, charts checked": "checking the charts, round 2, refinement",
    "ribbon, overlap cuts": "overlap cuts, refinement",
    "box, extra cuts": "extra cut 1, refinement",
    "sphere band, refinement 0": "refinement",
}


def _logged(V, F, options):
    calls = []
    result = parametrize(V, F, progress=lambda f, s: calls.append((f, s)), **options)
    return result, calls


@pytest.mark.parametrize("case", CASES)
def test_progress_rises_from_0_to_1_through_the_stages_and_changes_no_result(case):
    make, options = CASES[case]
    V, F = make()
    result, calls = _logged(V, F, options)
    fractions = np.array([f for f, _ in calls])
    stages = [s for _, s in calls]
    assert calls[0] == (0.0, "start") and calls[-1] == (1.0, "done")
    assert (np.diff(fractions) >= 0).all() and ((fractions >= 0) & (fractions <= 1)).all()
    for step in ("topology", "embedding", "placement"):  # the steps of every solve, named
        assert any(s.endswith(step) for s in stages), step
    assert ONE_OF_EACH_PATH[case] in stages
    plain = parametrize(V, F, **options)  # a callback watches, it does not steer
    assert np.array_equal(result.corner_uv, plain.corner_uv)


@pytest.mark.parametrize("case", CASES)
def test_a_cancel_in_any_stage_raises_cancelled_and_leaves_everything_as_it_was(case):
    make, options = CASES[case]
    V, F = make()
    V0, F0 = V.copy(), F.copy()
    first, calls = _logged(V, F, options)
    stages = list(dict.fromkeys(s for _, s in calls))
    assert len(stages) >= 8
    for stop in stages:
        seen = []

        def cancel_in(f, s, stop=stop, seen=seen):
            seen.append(s)
            return s != stop

        with pytest.raises(Cancelled, match="cancelled by the progress callback"):
            parametrize(V, F, progress=cancel_in, **options)
        assert seen[-1] == stop and seen.count(stop) == 1  # raised by the very call that asked
        assert np.array_equal(V, V0) and np.array_equal(F, F0)
    again = parametrize(V, F, **options)  # and nothing is left behind for the next solve
    assert np.array_equal(again.corner_uv, first.corner_uv)


def test_a_callback_that_returns_nothing_or_true_lets_the_solve_finish():
    V, F = ex.sphere_band()
    for answer in (None, True, 1):
        assert parametrize(V, F, progress=lambda f, s, a=answer: a).n_islands >= 1


def test_the_bunny_reports_often_and_stops_within_a_second_of_the_cancel():
    # issue 36's bar: charts and refinement on, at least 20 calls, fractions never
    # decreasing, the last 1.0; a callback that says stop at its fifth call is obeyed at once
    path = ex.SHARED / "stanford-bunny.obj"
    if not path.exists():
        pytest.skip(f"{path} is not on this machine (../shared/meshes)")
    V, F, _ = ex.load_obj(path)
    _, calls = _logged(V, F, dict(charts=True, refine=REFINE))
    fractions = [f for f, _ in calls]
    assert len(calls) >= 20 and fractions == sorted(fractions) and fractions[-1] == 1.0
    asked = []

    def fifth_says_stop(f, s):
        asked.append(time.perf_counter())
        return len(asked) < 5

    with pytest.raises(Cancelled):
        parametrize(V, F, charts=True, refine=REFINE, progress=fifth_says_stop)
    assert len(asked) == 5 and time.perf_counter() - asked[-1] < 1.0


@pytest.mark.parametrize("every", [0.0, np.inf])
def test_stages_share_their_parents_span_and_take_its_name(monkeypatch, every):
    monkeypatch.setattr(progress, "_EVERY", every)  # ticks within a stage: all, or none but stage changes
    calls = []
    with progress.tracking(lambda f, s: calls.append((round(f, 6), s))):
        with progress.stage("charting", 0.5, 0.9):
            with progress.stage("round 2", 0.5, 1.0):
                progress.tick(0.5)
            with progress.stage("", 0.0, 1.0):  # a span with no name of its own is its parent's
                pass
    ticked = [(0.8, "charting, round 2"), (0.9, "charting, round 2")] if every == 0 else []
    assert calls == [
        (0.0, "start"),
        (0.5, "charting"),
        (0.7, "charting, round 2"),
        *ticked,
        (0.9, "charting"),  # (back in the parent, at the child's end: never back down)
        *([(0.9, "charting")] * 2 if every == 0 else []),
        (1.0, "done"),
    ]


def test_rounds_of_unknown_number_share_the_span_without_overlap():
    spans = [progress.geometric(k) for k in range(1, 30)]
    assert spans[0] == (0.0, 0.5)
    assert all(a[1] == pytest.approx(b[0]) for a, b in zip(spans, spans[1:]))
    assert spans[-1][1] < 1.0
