"""Progress and cancel: what a long solve tells its caller as it goes, and how it stops.

:func:`.parametrize` takes ``progress=callable(fraction, stage)``. The solve is a tree of
stages (a charting round holds a solve, a solve holds the four steps and the refinement);
each stage owns a share of its parent's span, declared where the stage starts
(:func:`stage`), and reports how far it is inside that share (:func:`tick`). The callback
sees one fraction of the whole, never decreasing, and the stage's name; when it returns
``False`` the solve raises :class:`Cancelled` at once, from the very call that asked.

The tracker lives in a :class:`contextvars.ContextVar`, so the kernels need no extra
argument, a solve in another thread has its own (or none), and with no callback every
call here is a dictionary lookup and a return.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field

from .errors import IsoparamError

__all__ = ["Cancelled", "ProgressCallback", "geometric", "stage", "tick", "tracking"]

ProgressCallback = Callable[[float, str], "bool | None"]

_EVERY = 0.05  # seconds between two calls within one stage (stage changes always call)


class Cancelled(IsoparamError):  # noqa: N818 - a stop asked for, not an error: the name says it
    """The ``progress`` callback returned ``False``: the solve stopped, nothing was changed
    (the solver never writes to its inputs)."""


@dataclass
class _Tracker:
    callback: ProgressCallback
    spans: list[tuple[float, float, str]] = field(default_factory=lambda: [(0.0, 1.0, "")])
    fraction: float = 0.0  # how far the solve is (never decreasing)
    said: str | None = None  # the stage the callback was last told of
    at: float = float("-inf")  # when it was last called

    def report(self, within: float, force: bool = False) -> None:
        lo, hi, name = self.spans[-1]
        self.fraction = max(self.fraction, lo + min(max(within, 0.0), 1.0) * (hi - lo))
        now = time.perf_counter()
        if not (force or name != self.said or now - self.at >= _EVERY):
            return
        self.said, self.at = name, now
        answer = self.callback(self.fraction, name)
        if answer is not None and not answer:
            raise Cancelled(f"cancelled by the progress callback during {name or 'the solve'}")


_current: ContextVar[_Tracker | None] = ContextVar("isoparam_progress", default=None)


@contextlib.contextmanager
def tracking(callback: ProgressCallback | None) -> Iterator[None]:
    """Report to ``callback`` what the solve inside does: its first call says 0, its last
    1.0 (``stage`` ``"done"``), when the solve returns. ``None``: no reports."""
    if callback is None:
        yield
        return
    tracker = _Tracker(callback)
    token = _current.set(tracker)
    try:
        tracker.spans.append((0.0, 0.0, "start"))
        tracker.report(0.0, force=True)
        tracker.spans.pop()
        yield
        tracker.spans = [(0.0, 1.0, "done")]
        tracker.report(1.0, force=True)
    finally:
        _current.reset(token)


@contextlib.contextmanager
def stage(name: str, start: float, end: float) -> Iterator[None]:
    """The work inside is the stage ``name``, the share ``[start, end]`` (fractions) of the
    enclosing stage's span; it reports its own progress with :func:`tick`. A nested stage
    is named after its parent (``"charting, round 2, refinement"``); one named ``""`` is
    its parent's."""
    tracker = _current.get()
    if tracker is None:
        yield
        return
    lo, hi, parent = tracker.spans[-1]
    full = f"{parent}, {name}" if parent and name else (name or parent)
    tracker.spans.append((lo + start * (hi - lo), lo + end * (hi - lo), full))
    try:
        if full:  # (a span of the whole solve with no name of its own says nothing)
            tracker.report(0.0)
        yield
        if full:
            tracker.report(1.0)
    finally:
        tracker.spans.pop()


def tick(within: float = 0.0) -> None:
    """How far the current stage is, ``within`` in [0, 1]; raises :class:`Cancelled` if the
    callback, when called, asks to stop. Calls within a stage are thinned to one per
    ``_EVERY`` seconds: a loop may tick every iteration."""
    tracker = _current.get()
    if tracker is not None:
        tracker.report(within)


def geometric(k: int, share: float = 0.5) -> tuple[float, float]:
    """The span of the ``k``-th (from 1) of an unknown number of rounds: each takes
    ``share`` of what the ones before left, so any number of rounds fits in [0, 1]."""
    left = (1.0 - share) ** (k - 1)
    return 1.0 - left, 1.0 - left * (1.0 - share)
