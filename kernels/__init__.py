"""Warp kernels of wdendrite (installed as ``wdendrite.kernels``).

Every module here holds ``@wp.kernel`` and ``@wp.func`` definitions only; the
validated public functions that launch them live in :mod:`wdendrite`.
"""
