"""Concurrency: column-parallel sparse triangular solves, work beside the main thread, and
one BLAS thread throughout a solve.

SuperLU releases the GIL in ``SuperLU.solve`` (SciPy >= 0.18, SuperLU 5), and the
columns of a right-hand side are independent, so on large systems the columns are split
between the calling thread and one helper thread: a two-column solve of a 100k-vertex
mesh matrix takes ~23 ms instead of ~41 ms on this 2-core machine. The result agrees
with one call to rounding (~1e-13 relative: SuperLU's blocked multi-column kernels
round differently for different column counts) and is deterministic.
"""

from __future__ import annotations

import contextlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["background", "one_blas_thread", "solve_columns"]

PARALLEL_FROM = 20_000  # rows; below this a thread hand-off costs more than it saves

_pool: ThreadPoolExecutor | None = None
_lock = threading.Lock()


def _helper() -> ThreadPoolExecutor | None:
    global _pool
    if (os.cpu_count() or 1) < 2:
        return None
    with _lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isoparam-solve")
        return _pool


def solve_columns(lu, b: np.ndarray, trans: str = "N") -> np.ndarray:
    """``lu.solve(b, trans)`` with the columns of ``b`` (rows, p) shared by two threads."""
    if b.ndim != 2 or b.shape[1] < 2 or b.shape[0] < PARALLEL_FROM:
        return lu.solve(np.ascontiguousarray(b), trans=trans)
    pool = _helper()
    if pool is None:
        return lu.solve(np.ascontiguousarray(b), trans=trans)
    half = b.shape[1] // 2
    later = pool.submit(lu.solve, np.ascontiguousarray(b[:, half:]), trans)
    first = lu.solve(np.ascontiguousarray(b[:, :half]), trans=trans)
    return np.hstack([first, later.result()])


class _Inline:
    """A stand-in for a one-worker pool that runs a task when its result is asked for."""

    def submit(self, fn, *args) -> _Deferred:
        return _Deferred(fn, args)


class _Deferred:
    def __init__(self, fn, args):
        self.fn, self.args, self.value = fn, args, None

    def result(self):
        if self.fn is not None:  # run once, on first demand
            self.value, self.fn, self.args = self.fn(*self.args), None, None
        return self.value


@contextlib.contextmanager
def background(enabled: bool):
    """A one-worker pool for work that can run beside the calling thread (SuperLU and
    numpy release the GIL), or, when not ``enabled`` (small problems, where a thread
    hand-off costs more than it saves), a stand-in that runs each task on demand. An
    exception leaves without waiting for the task running beside (it ends on its own)."""
    if not enabled:
        yield _Inline()
        return
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isoparam-background")
    try:
        yield pool
    except BaseException:  # (a cancel): leave at once, the running task's result unread
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


@contextlib.contextmanager
def one_blas_thread():
    """BLAS (numpy's and scipy's OpenBLAS, MKL...) on one thread while a solve runs, by
    ``threadpoolctl`` (bundled with the add-on).

    A sum split over threads is rounded otherwise than one summed in order, so the same
    mesh would give other results with another thread count; and the solve keeps its own
    second thread busy beside the main one (:func:`background`, :func:`solve_columns`),
    so BLAS threads only compete with it: on this 2-core machine two BLAS threads were
    never faster, and 30% slower with the other core loaded (docs/benchmarks.md). Where
    ``threadpoolctl`` is missing (a plain Python install without it), BLAS runs as it is
    set."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a dependency of the add-on and of the tests
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield
