"""Edge weights evaluated per (node, direction) from a hash, with no weight array.

:func:`edge_weight` is the single definition of an edge's cost. The fill
kernel behind ``Distribution.sample()`` calls it for every stored entry, and a
shortest-path kernel may call it per edge instead of reading a weight array:
both get the same float32 value on the same device.

An edge is ``node <-> node + offset`` with ``offset`` the half-offset of
direction ``k`` (as ``wp.vec3i`` ``(dz, dy, dx)``; 2D lattices are ``(1, H, W)``)
and ``length`` its Euclidean length. Its weight is::

    length * (base + sum(add terms)) * prod(1 + multiply terms)

where ``base`` is drawn from ``hash_unit(seed, node, k)`` and each bias term
is ``strength * g ** exponent`` with a field ``g`` in [0, 1] evaluated at the
edge midpoint (ramp, radial) or as the mean of the two end nodes (map).
"""

import warp as wp

from . import OPTIONS
from .lattice import node_coords, node_index
from .indexing import nonneg
from .random import hash_unit

wp.set_module_options(OPTIONS)

# distribution kinds (WeightParams.kind)
CONSTANT = wp.constant(0)
UNIFORM = wp.constant(1)
POWER = wp.constant(2)
POLYNOMIAL = wp.constant(3)
REFINED = wp.constant(4)

# bias field kinds (BiasTerm.kind)
RAMP = wp.constant(0)
RADIAL = wp.constant(1)
MAP = wp.constant(2)

# how a bias term combines (BiasTerm.op)
ADD = wp.constant(0)
MULTIPLY = wp.constant(1)


@wp.struct
class BiasTerm:
    """One spatial bias term: ``strength * g ** exponent`` with a field ``g`` in [0, 1]."""

    kind: int
    """RAMP, RADIAL or MAP."""
    op: int
    """ADD (added to the base weight) or MULTIPLY (scales by ``1 + strength * g``)."""
    strength: float
    """Non-negative size of the term."""
    exponent: float
    """Positive shape exponent applied to ``g``."""
    invert: int
    """1: use ``1 - g`` (after clamping to [0, 1])."""
    direction: wp.vec3
    """RAMP: ``g = dot(direction, p) + offset`` at the edge midpoint ``p`` ``(z, y, x)``."""
    offset: float
    """RAMP: constant added to the ramp."""
    center: wp.vec3
    """RADIAL: a point on the vertical axis, ``(z, y, x)``."""
    horizontal: wp.vec3
    """RADIAL: 1 for horizontal coordinates, 0 for the vertical one."""
    inv_radius: float
    """RADIAL: ``1 / r_max`` so that ``g = r * inv_radius`` reaches 1 at the farthest node (0 if r_max is 0)."""
    map_start: int
    """MAP: index of the map's first node in ``WeightParams.maps``."""


@wp.struct
class WeightParams:
    """Everything :func:`edge_weight` needs: a distribution and its bias terms."""

    kind: int
    """CONSTANT, UNIFORM, POWER, POLYNOMIAL or REFINED."""
    seed: wp.uint32
    """Hash seed."""
    a: float
    """CONSTANT: value; UNIFORM: r; POWER: alpha; POLYNOMIAL: n; REFINED: e."""
    b: float
    """POWER: max (R is uniform in (1, max)); REFINED: n, fine nodes per coarse node; unused otherwise."""
    num_terms: int
    """Number of entries of ``terms`` in use."""
    terms: wp.array(dtype=BiasTerm)
    """Bias terms, applied in order (at least one entry, so the array is never empty)."""
    maps: wp.array(dtype=float)
    """Concatenated per-node map values in [0, 1] (at least one entry); REFINED: the
    coarse weights per unit length, node-major: ``(D, H, W, K)`` in C order."""
    grid: wp.vec3i
    """REFINED: coarse lattice shape ``(D, H, W)`` (interpolation is clamped to it)."""
    grid_start: wp.vec3i
    """REFINED: fine index of the window's first node in the whole fine lattice."""
    grid_k: int
    """REFINED: directions per coarse node in ``maps``."""
    grid_lo: wp.vec3i
    """REFINED: coarse index of the first coarse node held in ``maps``."""
    grid_span: wp.vec3i
    """REFINED: shape of the block of coarse nodes held in ``maps``."""
    links: wp.array(dtype=int)
    """REFINED: per coarse node of the block (C order), bit ``9 (dz + 1) + 3 (dy + 1) + dx + 1``
    set where fine edges may cross into the block of the neighbour at ``(dz, dy, dx)``; other
    crossings weigh inf (never taken). At least one entry."""


@wp.func
def drawn_weight(kind: int, seed: wp.uint32, a: float, b: float, node: int, k: int) -> float:
    """The random part of the weight of edge ``(node, k)`` of a CONSTANT, UNIFORM, POWER or
    POLYNOMIAL distribution (``kind``, ``seed``, ``a``, ``b`` as in :class:`WeightParams`),
    before length scaling. Scalars only: callers in tight loops need not pass the struct."""
    u = hash_unit(seed, wp.uint32(node), wp.uint32(k))
    w = a
    if kind == UNIFORM:
        w = 1.0 + a * u
    elif kind == POWER:
        w = wp.pow(1.0 + (b - 1.0) * u, a)
    elif kind == POLYNOMIAL:
        w = 1.0 + wp.pow(100.0 * u, a)
    return w


@wp.func
def is_plain(params: WeightParams) -> bool:
    """No bias terms and a drawn (not refined) distribution: an edge's weight is exactly
    ``length * drawn_weight(kind, seed, a, b, node, k)`` (the general form of
    :func:`edge_weight_of` adds 0 and scales by 1). Kernels that weigh many edges test
    this once and weigh through :func:`weight_of_edge`: on the CPU, passing the parameter
    struct down to a function per edge costs more than the hash."""
    return params.num_terms == 0 and params.kind != REFINED


@wp.func
def base_weight(params: WeightParams, node: int, k: int) -> float:
    """The random part of the weight of edge ``(node, k)``, before length scaling."""
    return drawn_weight(params.kind, params.seed, params.a, params.b, node, k)


@wp.func
def cell_of(c: int, o: int, half: float, inv_n: float, g: int) -> wp.vec3:
    """Interpolation cell along one axis of the fine edge from index ``c`` along offset ``o``:
    lower coarse index, upper coarse index (clamped to the grid) and the fraction between
    them, as floats. An edge's weight belongs at its midpoint: the fine edge's midpoint
    ``(c + o / 2 - half) / n`` is placed among the coarse edges' midpoints ``i + o / 2``."""
    x = wp.clamp((float(c) + 0.5 * float(o) - half) * inv_n - 0.5 * float(o), 0.0, float(g - 1))
    i = wp.min(int(wp.floor(x)), wp.max(g - 2, 0))
    return wp.vec3(float(i), float(wp.min(i + 1, g - 1)), wp.min(x - float(i), 1.0))


@wp.func
def refined_blocked(params: WeightParams, c: wp.vec3i, offset: wp.vec3i) -> bool:
    """Whether the REFINED edge from fine node ``c`` (index in the whole fine lattice) along
    ``offset`` crosses into a block ``links`` does not join to the node's (coarse node c / n).

    Along an axis it moves on, an edge leaves its block only from the block's last index
    forward or its first backward (fine indices are >= 0 inside the lattice; an edge leaving
    the lattice is never read). Divisions only where it moves.
    """
    ni = int(params.b)
    d = wp.vec3i(0, 0, 0)
    for axis in range(3):
        if offset[axis] != 0:
            r = c[axis] - (c[axis] / ni) * ni
            if (offset[axis] > 0 and r == ni - 1) or (offset[axis] < 0 and r == 0):
                d[axis] = offset[axis]
    out = False
    if d[0] != 0 or d[1] != 0 or d[2] != 0:
        lo = params.grid_lo
        s = params.grid_span
        at = (((c[0] / ni) - lo[0]) * s[1] + (c[1] / ni) - lo[1]) * s[2] + (c[2] / ni) - lo[2]
        bit = 9 * (d[0] + 1) + 3 * (d[1] + 1) + d[2] + 1
        if at >= 0 and at < params.links.shape[0]:
            if ((params.links[at] >> bit) & 1) == 0:
                out = True
    return out


@wp.func
def refined_key(params: WeightParams, c: wp.vec3i) -> wp.uint32:
    """Fine node ``c``'s index in the whole fine lattice (coarse shape times n), modulo 2**32."""
    un = wp.uint32(int(params.b))
    g = params.grid
    return wp.uint32(c[2]) + wp.uint32(g[2]) * un * (wp.uint32(c[1]) + wp.uint32(g[1]) * un * wp.uint32(c[0]))


@wp.func
def refined_value(params: WeightParams, k: int, cz: wp.vec3, cy: wp.vec3, cx: wp.vec3, key: wp.uint32) -> float:
    """``(e W_int + (1 - e) W_ran) / n`` of direction ``k`` from the edge's interpolation cells
    along each axis (:func:`cell_of`) and its node's :func:`refined_key`."""
    inv_n = 1.0 / params.b
    lo = params.grid_lo
    s = params.grid_span
    # node-major coarse weights of a block of the coarse lattice: the K directions of a
    # coarse node sit side by side
    nk = params.grid_k
    base = k
    z0 = ((int(cz[0]) - lo[0]) * s[1]) * s[2] * nk
    z1 = ((int(cz[1]) - lo[0]) * s[1]) * s[2] * nk
    y0 = (int(cy[0]) - lo[1]) * s[2] * nk
    y1 = (int(cy[1]) - lo[1]) * s[2] * nk
    x0 = (int(cx[0]) - lo[2]) * nk
    x1 = (int(cx[1]) - lo[2]) * nk
    m = params.maps
    tx = cx[2]
    ty = cy[2]
    tz = cz[2]
    w0 = (1.0 - ty) * ((1.0 - tx) * m[base + z0 + y0 + x0] + tx * m[base + z0 + y0 + x1]) + ty * (
        (1.0 - tx) * m[base + z0 + y1 + x0] + tx * m[base + z0 + y1 + x1]
    )
    w1 = (1.0 - ty) * ((1.0 - tx) * m[base + z1 + y0 + x0] + tx * m[base + z1 + y0 + x1]) + ty * (
        (1.0 - tx) * m[base + z1 + y1 + x0] + tx * m[base + z1 + y1 + x1]
    )
    w_int = (1.0 - tz) * w0 + tz * w1
    u = hash_unit(params.seed, key, wp.uint32(k))
    w_ran = 1.0 + (wp.max(w_int, 1.0) - 1.0) * u
    return (params.a * w_int + (1.0 - params.a) * w_ran) * inv_n


@wp.func
def refined_base(params: WeightParams, coords: wp.vec3i, k: int, offset: wp.vec3i) -> float:
    """REFINED base weight: ``(e W_int + (1 - e) W_ran) / n`` (Xu thesis 4.4) of the edge
    from the node at ``coords`` along ``offset``; inf where the edge crosses between blocks
    ``links`` does not join (:func:`refined_blocked`).

    ``W_int`` interpolates the coarse weights per unit length of direction ``k`` linearly at
    the fine edge's midpoint, among the coarse edges' midpoints (coarse node ``c`` sits at
    fine index ``c * n + n // 2``), and
    ``W_ran`` is uniform between 1 and ``W_int``, hashed from the node's index in the whole
    fine lattice (so a node's weights do not depend on the window).
    """
    c = coords + params.grid_start
    if refined_blocked(params, c, offset):
        return wp.inf
    n = params.b
    inv_n = 1.0 / n
    half = float(int(n) / 2)
    g = params.grid
    cz = cell_of(c[0], offset[0], half, inv_n, g[0])
    cy = cell_of(c[1], offset[1], half, inv_n, g[1])
    cx = cell_of(c[2], offset[2], half, inv_n, g[2])
    return refined_value(params, k, cz, cy, cx, refined_key(params, c))


@wp.func
def bias_field(
    term: BiasTerm, maps: wp.array(dtype=float), shape3: wp.vec3i, node: int, c: wp.vec3i, offset: wp.vec3i
) -> float:
    """The field value ``g ** exponent`` in [0, 1] of one bias term on edge ``node <-> node + offset``
    (``c``: the coordinates of ``node``)."""
    g = float(0.0)
    if term.kind == MAP:
        # mean of the two end nodes; an end outside the lattice counts as the inside end
        o = c + offset
        if o[0] < 0 or o[1] < 0 or o[2] < 0 or o[0] >= shape3[0] or o[1] >= shape3[1] or o[2] >= shape3[2]:
            o = c
        g = 0.5 * (maps[term.map_start + node] + maps[term.map_start + node_index(o, shape3)])
    else:
        p = wp.vec3(
            float(c[0]) + 0.5 * float(offset[0]),
            float(c[1]) + 0.5 * float(offset[1]),
            float(c[2]) + 0.5 * float(offset[2]),
        )
        if term.kind == RAMP:
            g = wp.dot(term.direction, p) + term.offset
        else:
            g = wp.length(wp.cw_mul(p - term.center, term.horizontal)) * term.inv_radius
    g = wp.clamp(g, 0.0, 1.0)
    if term.invert != 0:
        g = 1.0 - g
    if term.exponent != 1.0:
        g = wp.pow(g, term.exponent)
    return g


@wp.func
def edge_weight_of(
    params: WeightParams, shape3: wp.vec3i, node: int, coords: wp.vec3i, k: int, offset: wp.vec3i, length: float
) -> float:
    """The cost of edge ``node <-> node + offset`` (direction ``k``, Euclidean ``length``).

    Args:
        params: from ``distribution.kernel_params(shape, device)``.
        shape3: lattice shape ``(D, H, W)`` (D = 1 in 2D).
        node: flat index of the edge's first end (the one the half-offset starts from).
        coords: the same node as ``(z, y, x)``.
        k: direction index into the lattice's half-offsets.
        offset: the half-offset of direction ``k``, ``(dz, dy, dx)``.
        length: ``|offset|`` as float32 (1, sqrt(2) or sqrt(3)).
    """
    add = float(0.0)
    scale = float(1.0)
    i = int(0)
    while i < params.num_terms:  # (see kernels/indexing.py)
        term = params.terms[nonneg(i)]
        s = term.strength * bias_field(term, params.maps, shape3, node, coords, offset)
        if term.op == ADD:
            add = add + s
        else:
            scale = scale * (1.0 + s)
        i += 1
    base = float(0.0)
    if params.kind == REFINED:
        base = refined_base(params, coords, k, offset)
    else:
        base = base_weight(params, node, k)
    return length * (base + add) * scale


@wp.func
def weight_of_edge(
    params: WeightParams, plain: bool, shape3: wp.vec3i, node: int, coords: wp.vec3i, k: int, offset: wp.vec3i,
    length: float,
) -> float:
    """:func:`edge_weight_of`, taken from scalars when ``plain`` (:func:`is_plain` of ``params``,
    which callers weighing many edges test once)."""
    if plain:
        return length * drawn_weight(params.kind, params.seed, params.a, params.b, node, k)
    return edge_weight_of(params, shape3, node, coords, k, offset, length)


@wp.func
def edge_weight(params: WeightParams, shape3: wp.vec3i, node: int, k: int, offset: wp.vec3i, length: float) -> float:
    """:func:`edge_weight_of` for the edge starting at flat index ``node``."""
    return edge_weight_of(params, shape3, node, node_coords(node, shape3), k, offset, length)


@wp.func
def edge_weight_at(
    params: WeightParams, shape3: wp.vec3i, coords: wp.vec3i, k: int, offset: wp.vec3i, length: float
) -> float:
    """:func:`edge_weight_of` for the edge starting at node ``coords`` ``(z, y, x)``.

    For kernels whose own node numbering differs from the lattice's C order
    (a padded layout, a sublattice): the hash always uses the lattice's flat
    index, so the weight does not depend on how the caller stores nodes.
    """
    return edge_weight_of(params, shape3, node_index(coords, shape3), coords, k, offset, length)


@wp.kernel
def fill_weights_kernel(
    params: WeightParams,
    shape3: wp.vec3i,
    offsets_in: wp.array(dtype=wp.vec3i),
    lengths_in: wp.array(dtype=float),
    weights_out: wp.array2d(dtype=float),
):
    """Fill ``weights_out[k, node]`` for every direction and node; launch dim ``(K, N)``."""
    k, node = wp.tid()
    weights_out[k, node] = edge_weight(params, shape3, node, k, offsets_in[k], lengths_in[k])


@wp.kernel
def edge_weights_at_kernel(
    params: WeightParams,
    shape3: wp.vec3i,
    offsets_in: wp.array(dtype=wp.vec3i),
    lengths_in: wp.array(dtype=float),
    nodes_in: wp.array(dtype=int),
    directions_in: wp.array(dtype=int),
    weights_out: wp.array(dtype=float),
):
    """Weights of the listed edges ``(nodes_in[i], directions_in[i])``; launch dim ``(E,)``."""
    i = wp.tid()
    k = directions_in[i]
    # through the coordinate form, so that it is checked against the fill kernel too
    c = node_coords(nodes_in[i], shape3)
    weights_out[i] = edge_weight_at(params, shape3, c, k, offsets_in[k], lengths_in[k])
