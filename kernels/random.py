"""Stateless counter-based random numbers.

``hash_uniform(seed, node, stream)`` returns the same float in (0, 1) every
time it is asked with the same three integers, on every device, so lattice
weights can be recomputed inside a kernel instead of being stored.
"""

import warp as wp

from . import OPTIONS

wp.set_module_options(OPTIONS)

_MUL_A = wp.constant(wp.uint32(0x7FEB352D))
_MUL_B = wp.constant(wp.uint32(0x846CA68B))
_GOLDEN = wp.constant(wp.uint32(0x9E3779B9))
_SALT = wp.constant(wp.uint32(0x632BE5AB))


@wp.func
def mix32(x: wp.uint32) -> wp.uint32:
    """An avalanche mix of 32 bits (xor-shift-multiply rounds)."""
    x = x ^ (x >> wp.uint32(16))
    x = x * _MUL_A
    x = x ^ (x >> wp.uint32(15))
    x = x * _MUL_B
    x = x ^ (x >> wp.uint32(16))
    return x


@wp.func
def hash3(seed: wp.uint32, a: wp.uint32, b: wp.uint32) -> wp.uint32:
    """Hash three 32-bit words into one."""
    h = mix32(seed ^ _GOLDEN)
    h = mix32(h ^ a)
    h = mix32((h + _SALT) ^ b)
    return h


@wp.func
def hash_uniform(seed: wp.uint32, a: wp.uint32, b: wp.uint32) -> float:
    """A uniform float strictly inside (0, 1) from three integers."""
    h = hash3(seed, a, b)
    # 24 random bits centred in their interval never give 0 or 1 exactly
    return (float(h >> wp.uint32(8)) + 0.5) * (1.0 / 16777216.0)


@wp.func
def hash_unit(seed: wp.uint32, a: wp.uint32, b: wp.uint32) -> float:
    """A uniform float strictly inside (0, 1) from three integers, exact in float32.

    Uses the top 23 bits of :func:`hash3`: ``(h >> 9) + 0.5`` needs at most 24
    significant bits, so float32 holds it exactly and the result lies in
    ``[2**-24, 1 - 2**-24]``. (:func:`hash_uniform` keeps 24 bits, so its
    ``+ 0.5`` rounds in float32 and its largest value rounds up to 1.0.)
    """
    h = hash3(seed, a, b)
    return (float(h >> wp.uint32(9)) + 0.5) * (1.0 / 8388608.0)
