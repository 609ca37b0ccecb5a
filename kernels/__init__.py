"""Warp kernels of wdendrite (installed as ``wdendrite.kernels``).

Every module here holds ``@wp.kernel`` and ``@wp.func`` definitions only; the
validated public functions that launch them live in :mod:`wdendrite`.
"""

OPTIONS = {"enable_backward": False, "fuse_fp": False, "cpu_compiler_flags": "-march=native",
           "use_precompiled_headers": False}
"""Module options every kernel module sets: no gradients (none is ever needed, and the
backward code would double the compile time); for the CPU, code for the host's own instruction
set with LLVM's default inlining (Warp's default raises LLVM's inlining thresholds, which about
doubles the compile time for no run-time gain measured here, but in the search module and the
per-pixel Dendry kernels, which keep Warp's: see BENCHMARKS.md, "Start-up and kernel compilation"), and no precompiled header
(a process builds one for each set of compiler flags it meets, about 2 s each, while parsing the
header in each module costs a few tenths: a command loads three or four modules); and no fused
multiply-add. CUDA compilers fuse
``a * b + c`` into one rounding by default while the CPU build does not, so the same kernel
would round differently on the two devices, and two kernels evaluating one formula (weights
stored or recomputed, Dendry's cached and per-pixel modes, a search and its backtracking) could
round differently on a GPU. Without fusion both devices round every operation on its own.
"""

