"""Keep freed memory in the process while a large mesh is solved (Linux/glibc only).

glibc hands every allocation above 128 KiB-32 MiB straight back to the kernel when it
is freed, and the next large array faults fresh pages in. On virtual machines that
return free guest pages to the host (free-page reporting, DAMON reclaim), touching such
pages costs an order of magnitude more than reusing them: a million-vertex solve can
spend seconds in page faults. Inside :func:`retained`, glibc keeps
freed blocks for reuse; on exit the thresholds go back to glibc's defaults and
``malloc_trim(0)`` returns the memory, so the peak is unchanged and nothing stays
resident afterwards. Elsewhere this is a no-op.
"""

from __future__ import annotations

import contextlib
import ctypes
import sys

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_DEFAULT = 128 * 1024  # glibc's initial value of both thresholds


def _libc():
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt, libc.malloc_trim  # noqa: B018 - glibc only
        return libc
    except (OSError, AttributeError):
        return None


_LIBC = _libc()


@contextlib.contextmanager
def retained(enabled: bool = True):
    """Reuse freed memory inside the block; release it at the end."""
    if not enabled or _LIBC is None:
        yield
        return
    big = ctypes.c_int(2**31 - 1)
    _LIBC.mallopt(_M_MMAP_THRESHOLD, big)
    _LIBC.mallopt(_M_TRIM_THRESHOLD, big)
    try:
        yield
    finally:
        _LIBC.mallopt(_M_MMAP_THRESHOLD, ctypes.c_int(_DEFAULT))
        _LIBC.mallopt(_M_TRIM_THRESHOLD, ctypes.c_int(_DEFAULT))
        _LIBC.malloc_trim(0)
