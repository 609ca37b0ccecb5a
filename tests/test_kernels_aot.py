"""Every kernel module compiles for CUDA (through NVRTC, no GPU needed) and for the CPU.

Modules holding only ``@wp.func`` helpers cannot be compiled on their own;
they are compiled inside every kernel module that imports them, which the
last test checks.
"""

import importlib
import pkgutil
import re

import pytest
import warp as wp

import wdendrite.kernels as kernels_pkg

NAMES = sorted(m.name for m in pkgutil.iter_modules(kernels_pkg.__path__))
MODULES = {name: importlib.import_module(f"wdendrite.kernels.{name}") for name in NAMES}


def _has_kernels(module) -> bool:
    return any(isinstance(v, wp.Kernel) for v in vars(module).values())


WITH_KERNELS = [n for n in NAMES if _has_kernels(MODULES[n])]
FUNC_ONLY = [n for n in NAMES if not _has_kernels(MODULES[n])]


def test_kernel_modules_found():
    assert {"lattice", "random", "sssp", "weights"} <= set(NAMES)
    assert {"sssp", "weights"} <= set(WITH_KERNELS)


PTX_ONLY = {"dendry", "dendry_pixels"}
"""Modules compiled to PTX (NVRTC's C++ front end and optimizer, where CUDA source errors show)
without assembling the PTX into a cubin: for the Dendry module that last step alone took about
110 of the 200 s its cubin takes on a 2-core machine, more than a fifth of the whole suite (its
per-pixel kernels' module holds the same code)."""


@pytest.mark.parametrize("name", WITH_KERNELS)
def test_compiles_for_cuda(name, tmp_path):
    paths = wp.compile_aot_module(MODULES[name], arch=75, module_dir=tmp_path, use_ptx=name in PTX_ONLY)
    assert paths and all(p.exists() and p.stat().st_size > 0 for p in paths)
    if name in PTX_ONLY:  # a whole module's PTX for the architecture asked
        text = "".join(p.read_text(errors="ignore") for p in paths)
        assert ".target sm_75" in text and text.count(".entry") >= sum(
            isinstance(v, wp.Kernel) for v in vars(MODULES[name]).values())
        # the one resource limit PTX shows without assembling: a thread's local arrays (each
        # entry's depot) must fit the 512 KiB of local memory a CUDA thread can address
        depots = [int(v) for v in re.findall(r"__local_depot\d+\[(\d+)\]", text)]
        assert all(v < 512 * 1024 for v in depots), depots


@pytest.mark.parametrize("name", WITH_KERNELS)
def test_compiles_for_cpu(name):
    wp.load_module(MODULES[name], device="cpu")


@pytest.mark.parametrize("name", FUNC_ONLY)
def test_helper_module_used_by_a_kernel_module(name):
    helper_funcs = {id(v) for v in vars(MODULES[name]).values() if isinstance(v, wp.Function)}
    assert helper_funcs
    users = [n for n in WITH_KERNELS if helper_funcs & {id(v) for v in vars(MODULES[n]).values()}]
    assert users, f"kernels/{name}.py is imported by no kernel module, so nothing compiles it"


@pytest.mark.parametrize("name", WITH_KERNELS)
def test_no_fused_multiply_add(name, tmp_path):
    # CUDA compilers fuse a * b + c into one rounding unless told not to; the CPU build does not,
    # so kernel modules turn fusion off (kernels.OPTIONS) for both devices to round alike
    module = wp.get_module(MODULES[name].__name__)
    assert module.options["fuse_fp"] is False and module.options["enable_backward"] is False
    # in the CUDA code of the weights (recomputed weights must equal the stored ones, which the
    # CPU computes), every float multiplication and addition rounds on its own (".rn", which
    # forbids contraction; fma instructions remain only inside the math library's pow)
    if name == "weights":
        ptx = wp.compile_aot_module(MODULES[name], arch=75, module_dir=tmp_path, use_ptx=True)
        text = "".join(p.read_text(errors="ignore") for p in ptx)
        assert re.search(r"\bmul\.rn\.f32", text)
        assert not re.search(r"\b(mul|add|sub)\.f32\b", text)
