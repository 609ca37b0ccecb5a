"""Warp kernels of wdendrite (installed as ``wdendrite.kernels``).

Every module here holds ``@wp.kernel`` and ``@wp.func`` definitions only; the
validated public functions that launch them live in :mod:`wdendrite`.
"""

OPTIONS = {"enable_backward": False, "fuse_fp": False}
"""Module options every kernel module sets: no gradients (none is ever needed, and the
backward code would double the compile time), and no fused multiply-add. CUDA compilers fuse
``a * b + c`` into one rounding by default while the CPU build does not, so the same kernel
would round differently on the two devices, and two kernels evaluating one formula (weights
stored or recomputed, Dendry's cached and per-pixel modes, a search and its backtracking) could
round differently on a GPU. Without fusion both devices round every operation on its own.
"""

