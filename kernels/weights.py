"""Edge-weight distributions evaluated per (node, direction) from a hash."""

import warp as wp

from .random import hash_uniform

wp.set_module_options({"enable_backward": False})


@wp.func
def uniform_weight(seed: wp.uint32, scale: float, length: float, node: int, direction: int) -> float:
    """``length * (1 + scale * R)`` with R uniform in (0, 1) (Xu & Mould's uniform weights)."""
    r = hash_uniform(seed, wp.uint32(node), wp.uint32(direction))
    return length * (1.0 + scale * r)


@wp.kernel
def uniform_weights_kernel(
    seed: wp.uint32,
    scale: float,
    lengths: wp.array(dtype=float),
    count: int,
    weights_out: wp.array(dtype=float),
):
    """Fill the flat ``(K * N,)`` weight array; thread ``k * N + node``."""
    e = wp.tid()
    k = e / count
    weights_out[e] = uniform_weight(seed, scale, lengths[k], e - k * count, k)
