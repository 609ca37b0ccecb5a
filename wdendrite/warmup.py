"""Compiling every kernel module up front: ``wd.load_kernels()`` and ``wdendrite warmup``.

Warp compiles a kernel module the first time one of its kernels runs on a device and keeps
the binary in its kernel cache (``~/.cache/warp``, or ``WARP_CACHE_PATH``), so a new user's
first command pays for the modules it uses. :func:`load_kernels` pays for all of them at once,
several modules at a time: for a notebook's first cell, a CI job's first step or a container
image, after which no command compiles again (until Warp, the package or the CPU changes).
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import time

__all__ = ["kernel_modules", "load_kernels"]


def kernel_modules() -> list:
    """The Python modules of ``wdendrite.kernels`` that hold kernels (each one Warp module), by name.

    Modules holding only ``@wp.func`` helpers are left out: they are compiled inside the
    kernel modules that use them.
    """
    import warp as wp

    from . import kernels as pkg

    found = []
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{pkg.__name__}.{info.name}")
        if any(isinstance(v, wp.Kernel) for v in vars(module).values()):
            found.append(module)
    return found


def load_kernels(device=None, *, workers: int | None = None, progress: bool = True) -> dict[str, float]:
    """Compile (or load from Warp's kernel cache) every kernel module of the package for ``device``.

    Args:
        device: a Warp device or its name (``"cpu"``, ``"cuda:0"``); None: Warp's default device.
        workers: modules compiled at the same time, each on a thread of its own (Warp's compiler
            releases the interpreter), >= 1; None: the number of CPUs, at most the number of
            modules. Each thread also builds Warp's precompiled header once, so more workers cost
            more CPU time in all and take less wall time on a machine with idle cores.
        progress: a progress bar on stderr.

    Returns:
        ``{module name: seconds}``: the wall seconds each module took to compile or load, by its
        short name (``"sssp"``), in the order of the package's modules.

    Raises:
        ValueError: ``workers`` is not a positive integer, or ``device`` names no device of
            this machine.
    """
    import warp as wp

    from ._spec import progress_bar

    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"Expected a positive integer for 'workers', but got {workers!r}")
    wp.init()
    try:
        dev = wp.get_device(device)
    except (RuntimeError, ValueError) as exc:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise ValueError(f"Expected a device of this machine for 'device' ({names}), but got {device!r}") from exc
    modules = kernel_modules()
    if workers is None:
        workers = os.cpu_count() or 1
    workers = max(1, min(workers, len(modules)))
    seconds = {}

    def load(module):
        t = time.perf_counter()
        wp.load_module(module, device=dev, max_workers=0)
        return module.__name__.rsplit(".", 1)[-1], time.perf_counter() - t

    with progress_bar(f"kernels for {dev}", quiet=not progress, total=len(modules)) as bar:
        if workers == 1:
            for module in modules:
                name, s = load(module)
                seconds[name] = s
                bar.update(1)
        else:
            from concurrent.futures import ThreadPoolExecutor, as_completed

            with ThreadPoolExecutor(max_workers=workers) as pool:
                for future in as_completed([pool.submit(load, m) for m in modules]):
                    name, s = future.result()
                    seconds[name] = s
                    bar.update(1)
    order = [m.__name__.rsplit(".", 1)[-1] for m in modules]
    return {name: seconds[name] for name in order}
