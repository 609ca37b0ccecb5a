"""Dendry's per-pixel kernels for the CPU, compiled with their loops left rolled.

These are :func:`wdendrite.kernels.dendry.image_kernel` and ``points_kernel`` with the mode
fixed to per-pixel (so the compiler drops the cached mode's branches) in a module whose
loops Warp does not unroll (``max_unroll`` 1). A per-pixel evaluation runs the whole
pipeline once per pixel, and unrolled (5 x 5 primitives, pieces, neighbourhoods) it spans
about 280 KB of machine code, far beyond a core's instruction cache; rolled, the CPU runs it
about 5 % faster for elevations (distances: within 3 %). Both modules call the same
functions, so the values are the same bit for bit. On CUDA the host keeps the unrolled
kernels: there rolled loops would index the per-thread arrays at run time, which moves them
to local memory.
"""

import warp as wp

from . import OPTIONS
from .dendry import Setup, evaluate, pixel_centre, pixel_of
from .noise import Control

# Warp's own CPU flags (its raised inlining thresholds): with LLVM's defaults the per-pixel kernels
# ran at about half the speed (BENCHMARKS.md, "Start-up and kernel compilation")
wp.set_module_options({**OPTIONS, "cpu_compiler_flags": None, "max_unroll": 1})


@wp.kernel
def image_kernel(
    s: Setup, ctl: Control, output: int, cap: wp.vec3i, nslots: int, first: int, origin: wp.vec2i, width: int,
    x0: wp.vec2, step: wp.vec2,
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims: wp.array(dtype=wp.vec3),
    nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float), image_out: wp.array2d(dtype=float),
    overflow_out: wp.array(dtype=int),
):
    """Per-pixel mode of :func:`wdendrite.kernels.dendry.image_kernel` (same arguments but ``cached``)."""
    t = wp.tid()
    rc = pixel_of(first + t, width)
    image_out[rc[0], rc[1]] = evaluate(
        s, ctl, pixel_centre(rc, origin, x0, step), output, 0, t % nslots, cap, blocks, bases, pts1, keyp, verts,
        prims, nearby, gaps, overflow_out,
    )


@wp.kernel
def points_kernel(
    s: Setup, ctl: Control, output: int, cap: wp.vec3i, nslots: int, first: int, points_in: wp.array(dtype=wp.vec2),
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims: wp.array(dtype=wp.vec3),
    nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float), values_out: wp.array(dtype=float),
    overflow_out: wp.array(dtype=int),
):
    """Per-pixel mode of :func:`wdendrite.kernels.dendry.points_kernel` (same arguments but ``cached``)."""
    t = wp.tid()
    i = first + t
    values_out[i] = evaluate(
        s, ctl, points_in[i], output, 0, t % nslots, cap, blocks, bases, pts1, keyp, verts, prims, nearby, gaps,
        overflow_out,
    )
