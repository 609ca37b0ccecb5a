"""Array indexing helpers shared by the kernel modules.

Warp wraps negative array indices as Python does, so every load or store
through ``arr[i]`` carries a test and an add (``if i < 0: i += shape``) the
compiler can only drop when it knows ``i`` is not negative. Indices in these
kernels never are; :func:`nonneg` says so by clearing the sign bit, which
leaves every valid index unchanged and costs one ``and``.

A related finding: a ``for j in range(a, b)`` loop with run-time bounds
compiled to a slower loop than the same ``while j < b`` loop (the band pass
over a lattice took 0.6-0.7x the time as a ``while``, Dendry's cell scan
0.8-0.9x), so the hot loops with run-time bounds are written as ``while``
loops.

Arrays passed to a kernel carry their strides at run time, so an element's
address costs a multiplication by a stride loaded from the array. A view made
inside the kernel from the array's pointer (:func:`dense_i32`,
:func:`dense_u64`) has a stride the compiler knows, the element size: in the
one-launch search that took 0.93-0.94x the time of the same search through the
arrays as passed.
"""

import warp as wp

from . import OPTIONS

wp.set_module_options(OPTIONS)


@wp.func
def nonneg(i: int) -> int:
    """Array index ``i`` (never negative here) with its sign bit cleared, so that the
    compiler drops Warp's negative-index wrap (on the CPU 10-20 % of a search)."""
    return i & 0x7FFFFFFF


@wp.func
def dense_i32(a: wp.array(dtype=wp.int32)) -> wp.array(dtype=wp.int32):
    """A view of the contiguous int32 array ``a`` whose element stride the compiler knows."""
    return wp.array(ptr=a.ptr, shape=(a.shape[0],), dtype=wp.int32)


@wp.func
def dense_u64(a: wp.array(dtype=wp.uint64)) -> wp.array(dtype=wp.uint64):
    """A view of the contiguous uint64 array ``a`` whose element stride the compiler knows."""
    return wp.array(ptr=a.ptr, shape=(a.shape[0],), dtype=wp.uint64)
