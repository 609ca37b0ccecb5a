"""Host memory advice for large CPU arrays.

Lattice-sized arrays are read at random by the shortest-path kernels; with
4 KiB pages a 3D search spends much of its time on TLB misses. Where the
kernel allows it (transparent huge pages in ``madvise`` or ``always`` mode),
asking for 2 MiB pages before an array is first touched removes most of them
(and for lattice-sized outputs, most of the page faults of their first touch).
This is advice only: where it is not available nothing changes. The other way
round, tables that get only a few scattered writes (:func:`sparse_table`)
decline the huge pages NumPy asks for, which each such write would zero whole.
"""

from __future__ import annotations

import ctypes
import mmap
import ctypes.util
import sys

import numpy as np
import warp as wp

_MADV_HUGEPAGE = 14
_HUGE = 2 << 20
_libc = None


def _madvise():
    global _libc
    if _libc is None:
        if not sys.platform.startswith("linux"):
            _libc = False
        else:
            try:
                lib = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
                lib.madvise.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
                lib.madvise.restype = ctypes.c_int
                _libc = lib
            except OSError:
                _libc = False
    return _libc or None


def advise_huge_pages(arr: wp.array) -> bool:
    """Ask for huge pages behind a fresh (untouched) CPU array of at least 4 MiB.

    Returns True when the advice was given; False for GPU arrays, small
    arrays or systems without ``madvise``.
    """
    if not arr.device.is_cpu or arr.capacity < 2 * _HUGE:
        return False
    lib = _madvise()
    if lib is None:
        return False
    start = (arr.ptr + _HUGE - 1) // _HUGE * _HUGE
    end = (arr.ptr + arr.capacity) // _HUGE * _HUGE
    return end > start and lib.madvise(start, end - start, _MADV_HUGEPAGE) == 0


def empty(shape, dtype, device) -> wp.array:
    """``wp.empty`` with huge-page advice for large CPU arrays (contents undefined)."""
    arr = wp.empty(shape, dtype=dtype, device=device)
    advise_huge_pages(arr)
    return arr


def _fresh_mapping(nbytes: int, huge: bool):
    """A fresh private anonymous mapping of ``nbytes`` whose zero pages cost nothing until
    touched, or None for small sizes (under 4 MiB, where a mapping of their own gains nothing)
    and systems without private anonymous mappings (Windows, through the mmap module).

    Without ``huge`` it declines huge pages, which systems in THP "always" mode would otherwise
    hand out and zero 2 MiB at a time; with ``huge`` the caller asks for them on the array it
    lays over the mapping (:func:`advise_huge_pages`).
    """
    if nbytes < 2 * _HUGE or not hasattr(mmap, "MAP_PRIVATE"):
        return None
    block = mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE)  # private: eligible for huge pages
    if not huge and hasattr(mmap, "MADV_NOHUGEPAGE"):
        block.madvise(mmap.MADV_NOHUGEPAGE)
    return block


def zeros(count: int, dtype, device, *, huge: bool = True) -> wp.array:
    """A zero-filled 1D array of ``count`` elements whose zeros cost nothing until touched.

    On the CPU the memory is a fresh anonymous mapping: the system hands out
    zero pages on first touch, so a large array of which a kernel touches a
    small part (a sparse lattice's records) costs only the pages it touches.
    ``huge`` asks for 2 MiB pages (for arrays that will be touched throughout);
    without it they are declined. Small arrays (under 4 MiB) and other devices
    get ``wp.zeros``.
    """
    device = wp.get_device(device)
    nbytes = max(1, count * wp.types.type_size_in_bytes(dtype))
    block = _fresh_mapping(nbytes, huge) if device.is_cpu else None
    if block is None:
        return wp.zeros(count, dtype=dtype, device=device)
    ptr = ctypes.addressof(ctypes.c_char.from_buffer(block))
    arr = wp.array(ptr=ptr, dtype=dtype, shape=(count,), device=device)
    arr._anonymous_mapping = block  # the array keeps its memory alive
    if huge:
        advise_huge_pages(arr)
    return arr


def sparse_table(count: int, dtype) -> np.ndarray:
    """A zero-filled 1D NumPy array of ``count`` elements for scattered writes to a few of them
    (a table over a lattice's nodes of which a dendrite touches some).

    NumPy asks for huge pages behind its large arrays, so each scattered write into a fresh
    one zeroes a whole 2 MiB page: a walk table over the 408 M padded nodes of a refined
    lattice (n = 15) took 3.5 s for about 10 000 entries. This one sits on a fresh mapping
    without huge pages (:func:`_fresh_mapping`), whose 4 KiB zero pages cost only where
    written (small tables are plain NumPy arrays). A table written densely pays a page fault
    per page instead (about 1 us per 4 KiB, where huge pages would zero 2 MiB at a time).
    """
    dtype = np.dtype(dtype)
    block = _fresh_mapping(max(1, count * dtype.itemsize), huge=False)
    if block is None:
        return np.zeros(count, dtype)
    return np.frombuffer(block, dtype, count)  # the array keeps the mapping alive
