"""Isometric Unwrap in the background: the solve in a worker thread, watched from the modal
operator's events, with progress shown and Esc to cancel."""

from __future__ import annotations

import threading

from ..operation.options import OperatorOptions
from . import unwrap
from .modes import object_mode
from .record import RunRecord

__all__ = ["Background"]


_POLL = 0.1  # seconds between two looks at a solve running in the background


# events a modal unwrap lets through: looking around the scene changes nothing
_NAVIGATION = frozenset(
    {
        "MIDDLEMOUSE",
        "WHEELUPMOUSE",
        "WHEELDOWNMOUSE",
        "MOUSEMOVE",
        "INBETWEEN_MOUSEMOVE",
        "TRACKPADPAN",
        "TRACKPADZOOM",
        "MOUSEROTATE",
        "MOUSESMARTZOOM",
        "NDOF_MOTION",
    }
)


class Background:
    """An :class:`Unwrap` whose solve runs in a worker thread while a modal operator
    watches it (:meth:`on_event`): the progress shows in Blender's progress indicator and
    status bar, Esc cancels, and every other event that could edit the mesh is held back
    until the run ends (looking around the scene still works); then :meth:`conclude`
    writes and returns the run's record."""

    def __init__(self, context, opts: OperatorOptions):
        self.job = unwrap.Unwrap(context, opts)
        self.thread: threading.Thread | None = None
        self.timer = None
        with object_mode(context):
            if not self.job.read():
                return
        self.thread = threading.Thread(target=self.job.solve, name="isoparam-unwrap", daemon=True)
        self.thread.start()
        wm = context.window_manager
        if context.window is not None:
            self.timer = wm.event_timer_add(_POLL, window=context.window)
        wm.progress_begin(0.0, 1.0)

    @property
    def running(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    def on_event(self, context, kind: str, value: str = "PRESS") -> set | None:
        """What the modal operator returns for an event of type ``kind`` while the run goes
        on; None once the solve has ended (then the operator calls :meth:`conclude`)."""
        if kind == "ESC" and value == "PRESS":
            self.job.cancel_requested = True
        elif kind in _NAVIGATION:
            return {"PASS_THROUGH"}
        if self.running:
            if kind == "TIMER":
                self._show(context)
            return {"RUNNING_MODAL"}
        return None

    def conclude(self, context) -> RunRecord:
        """Once the solve has ended: write and finish, or say why not; the run's record."""
        self._close(context)
        job = self.job
        if self.thread is None or job.error or job.cancelled or job.cancel_requested:
            return job.refuse()
        with object_mode(context):
            job.write()
        return job.finish(context)

    def _show(self, context) -> None:
        context.window_manager.progress_update(self.job.fraction)
        what = "cancelling" if self.job.cancel_requested else f"{self.job.stage}, {self.job.fraction:.0%}"
        _status(context, f"Isometric Unwrap: {what} (Esc to cancel)")

    def _close(self, context) -> None:
        wm = context.window_manager
        if self.timer is not None:
            wm.event_timer_remove(self.timer)
            self.timer = None
        if self.thread is not None:
            wm.progress_end()
        _status(context, None)


def _status(context, text: str | None) -> None:
    workspace = getattr(context, "workspace", None)
    if workspace is not None:
        workspace.status_text_set(text)
