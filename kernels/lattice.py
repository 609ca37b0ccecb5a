"""Index helpers shared by lattice kernels.

Every lattice is handled as 3D inside kernels: a 2D ``(H, W)`` lattice is the
3D lattice ``(1, H, W)``. ``shape`` is ``wp.vec3i(D, H, W)`` and a node's flat
index is ``(z * H + y) * W + x`` (C order, the same as NumPy's ``ravel``).
"""

import warp as wp

from . import OPTIONS

wp.set_module_options(OPTIONS)


@wp.func
def node_coords(index: int, shape: wp.vec3i) -> wp.vec3i:
    """Return ``(z, y, x)`` of the node with flat ``index``."""
    plane = shape[1] * shape[2]
    z = index / plane
    rem = index - z * plane
    y = rem / shape[2]
    return wp.vec3i(z, y, rem - y * shape[2])


@wp.func
def node_index(coords: wp.vec3i, shape: wp.vec3i) -> int:
    """Return the flat index of the node at ``(z, y, x)``."""
    return (coords[0] * shape[1] + coords[1]) * shape[2] + coords[2]


@wp.func
def in_bounds(coords: wp.vec3i, shape: wp.vec3i) -> bool:
    """True where ``coords`` lies inside a lattice of ``shape``."""
    return (
        coords[0] >= 0
        and coords[1] >= 0
        and coords[2] >= 0
        and coords[0] < shape[0]
        and coords[1] < shape[1]
        and coords[2] < shape[2]
    )


@wp.func
def padded_index(index: int, shape: wp.vec3i, pad: wp.vec3i) -> int:
    """Flat index, in a lattice padded by ``pad`` nodes on each side, of the node with flat ``index``.

    Shortest-path kernels work on a lattice with a one-node border of blocked
    nodes, so a neighbour is always ``node + flat_offset`` with no bounds test.
    """
    c = node_coords(index, shape) + pad
    return node_index(c, shape + pad + pad)
