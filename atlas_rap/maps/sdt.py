"""The skeletonized distance transform (seed §4.2): distance transform, places, skeleton, stochastic SDT.

From an occupancy grid ``p_occ`` (NaN = unknown) placed by a
:class:`~atlas_rap.maps.frame.GridFrame`:

1. **free space** -- the cells with P(occ) < ``free_below`` (0.5): the
   support of the seed's transformed map M' (equation (2)); unknown cells
   are not free.
2. **distance transform** (:func:`distance_transform`) -- metres from each
   free cell's centre to the nearest non-free cell's centre
   (``scipy.ndimage.distance_transform_edt``), the grid padded with obstacle
   so that its border counts as a wall.
3. **skeleton** (:func:`skeleton`) -- ``skimage.morphology.skeletonize`` of
   the free cells whose clearance exceeds the robot's radius: the skeleton
   of the DT cut at the robot's size, i.e. of the space the robot's centre
   can occupy. Passages narrower than the robot do not appear, and bumps
   smaller than the robot are smoothed away before thinning.
4. **segments** -- the skeleton split at its junctions (:func:`trace_skeleton`,
   vectorised: neighbour counts, connected components with
   ``scipy.sparse.csgraph`` and one breadth-first search orders every
   pixel path at once), pruned of spurs and with close junctions merged
   (:mod:`atlas_rap.maps.topology`). Each segment is **stochastic**: it
   carries the probability that it is empty, from its support in the grid
   (:func:`cell_support`): at each skeleton cell, the smallest 1 - P(occ)
   (NaN counted as 0.5) over a disc of the robot's radius around it -- the
   band the robot sweeps; along the segment these are combined as
   independent once per robot diameter, ``P = prod p_i ** (ds_i / 2r)``, so
   ``cost = -log P = sum -log(p_i) ds_i / 2r`` adds along routes (the most
   probable route is the cheapest) and a long corridor is not penalised
   cell by cell for evidence that neighbouring cells share.
5. **places** -- rooms and corridors, found on the skeleton's critical
   points and cut along the doorways in the walls
   (:mod:`atlas_rap.maps.rooms`, with settings in metres).
6. **topology** -- :class:`atlas_rap.maps.topology.Topology`.

:func:`atlas_rap.maps.abstraction.abstract` runs the whole pipeline and
returns every level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from atlas_rap.maps.frame import GridFrame

__all__ = [
    "SDT", "SkeletonSegment", "SkeletonTrace", "cell_support", "distance_transform",
    "free_space", "segment_costs", "skeleton", "trace_skeleton",
]

UNKNOWN_SUPPORT = 0.5
"""1 - P(occ) counted for an unknown (NaN) cell."""

MIN_PROBABILITY = 1e-9
"""Floor of a cell's probability of being empty, so that costs stay finite."""


# -- levels ---------------------------------------------------------------------

def free_space(p_occ: np.ndarray, free_below: float = 0.5) -> np.ndarray:
    """Cells with P(occ) < ``free_below`` (NaN, unknown, is not free): where equation (2)'s M' is non-zero."""
    with np.errstate(invalid="ignore"):
        return np.asarray(p_occ) < free_below


def distance_transform(free_mask: np.ndarray, frame: GridFrame, *, nearest: bool = False):
    """Metres from each free cell's centre to the nearest non-free cell's centre (0 off the free space).

    The grid is padded with one ring of obstacle, so the border of the map
    counts as a wall (nothing is known to be free beyond it). With
    ``nearest``, also the feature transform the distances come from: a
    (2, H, W) int32 array of the row and column of each cell's nearest
    non-free cell (a cell of the border ring is given as the edge cell next
    to it), as ``(dt, nearest)``; it costs no second pass.
    """
    free = np.asarray(free_mask, dtype=bool)
    if free.shape != frame.shape:
        raise ValueError(f"free_mask has shape {free.shape}, but the frame is {frame.height} x {frame.width}")
    padded = np.pad(free, 1, constant_values=False)
    if not nearest:
        dt = ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
        dt *= frame.resolution
        return dt
    dt, indices = ndimage.distance_transform_edt(padded, return_indices=True)
    dt = dt[1:-1, 1:-1] * frame.resolution
    indices = indices[:, 1:-1, 1:-1]
    indices -= 1
    np.clip(indices[0], 0, frame.height - 1, out=indices[0])
    np.clip(indices[1], 0, frame.width - 1, out=indices[1])
    return dt, indices


def skeleton(dt: np.ndarray, free_mask: np.ndarray, clearance: float = 0.0) -> np.ndarray:
    """Skeleton (``skimage.morphology.skeletonize``) of the free cells whose clearance ``dt`` exceeds ``clearance``.

    ``dt`` and ``clearance`` are in the same unit (metres from
    :func:`distance_transform`). With the robot's radius as ``clearance``
    this is the skeleton of the robot's configuration space.
    """
    from skimage.morphology import skeletonize

    room = np.asarray(free_mask, dtype=bool)
    if clearance > 0:
        room = room & (dt > clearance)
    return skeletonize(room)


# -- tracing ---------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class SkeletonTrace:
    """A skeleton split at its junctions: nodes and the pixel paths between them.

    ``node_cells`` (K, 2) are (row, col) of the nodes: junctions first
    (``junctions`` of them; each a cluster of skeleton pixels with three or
    more neighbours, represented by its pixel of largest clearance), then
    path ends (skeleton pixels with one neighbour) and lone pixels or rings.
    ``pixels`` (P, 2) are the path pixels, ordered path by path;
    segment ``i`` runs from node ``seg_u[i]`` through ``pixels[seg_start[i]:
    seg_stop[i]]`` to node ``seg_v[i]`` (``seg_u == seg_v`` for a ring).
    ``seg_length`` is its length in cells, node to node.
    """

    node_cells: np.ndarray
    junctions: int
    pixels: np.ndarray
    seg_u: np.ndarray
    seg_v: np.ndarray
    seg_start: np.ndarray
    seg_stop: np.ndarray
    seg_length: np.ndarray

    def cells(self, i: int) -> np.ndarray:
        """(row, col) of segment ``i`` from its first node to its last, both included."""
        inner = self.pixels[self.seg_start[i]:self.seg_stop[i]]
        u, v = self.node_cells[self.seg_u[i]], self.node_cells[self.seg_v[i]]
        parts = [inner]
        if not (len(inner) and (inner[0] == u).all()):
            parts.insert(0, u[None, :])
        if not (len(inner) and (inner[-1] == v).all()) or (self.seg_u[i] == self.seg_v[i] and len(inner) > 1):
            parts.append(v[None, :])
        return np.concatenate(parts)


def _empty_trace() -> SkeletonTrace:
    none = np.zeros(0, dtype=np.int64)
    return SkeletonTrace(np.zeros((0, 2), dtype=np.int64), 0, np.zeros((0, 2), dtype=np.int64),
                         none, none, none, none, np.zeros(0))


def trace_skeleton(skel: np.ndarray, dt: np.ndarray | None = None) -> SkeletonTrace:
    """Split a skeleton at its junctions into pixel paths (vectorised; see :class:`SkeletonTrace`).

    Pixels are 8-connected, except that a diagonal step is not counted when
    a 4-connected pair of steps joins the same two pixels (so a staircase is
    a path, not a chain of triangles). Junction pixels have three or more
    neighbours; touching junction pixels form one junction, placed at its
    pixel of largest ``dt`` (its first pixel without ``dt``).

    The steps: the pixels' neighbour pairs; the junction clusters; the
    junctions each path pixel touches; the chains of path pixels, each cut
    open where it is a ring and put in order; their end nodes; their lengths.
    """
    skel = np.ascontiguousarray(skel, dtype=bool)
    width = skel.shape[1]
    idx = np.flatnonzero(skel.ravel())
    n = idx.size
    if n == 0:
        return _empty_trace()
    rows, cols = np.divmod(idx, width)
    src, dst = _neighbour_pairs(skel, idx, rows, cols)
    junction = (np.bincount(src, minlength=n) + np.bincount(dst, minlength=n)) >= 3
    n_junctions, cluster, rep = _junction_clusters(junction, src, dst, idx, dt)
    path = ~junction
    ppix = np.flatnonzero(path)
    if ppix.size == 0:
        node_cells = np.column_stack([rows[rep], cols[rep]])
        return SkeletonTrace(node_cells, n_junctions, np.zeros((0, 2), dtype=np.int64),
                             *(np.zeros(0, dtype=np.int64),) * 4, np.zeros(0))
    touch1, touch2 = _junctions_touched(path, src, dst, cluster)
    pp = path[src] & path[dst]
    chains = _order_chains(src[pp], dst[pp], ppix, n)
    ends = _chain_ends(chains, touch1, touch2, rep, n_junctions)
    length = _chain_lengths(chains, ends, rows, cols)
    node_pix = np.concatenate([rep, ends.extra_pixels])
    node_cells = np.column_stack([rows[node_pix], cols[node_pix]])
    pixels = np.column_stack([rows[chains.ordered], cols[chains.ordered]])
    keep = ends.keep
    return SkeletonTrace(node_cells, n_junctions, pixels, ends.u[keep], ends.v[keep], chains.seg_start[keep],
                         chains.seg_stop[keep], length[keep])


def _neighbour_pairs(skel: np.ndarray, idx: np.ndarray, rows: np.ndarray,
                     cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The skeleton's neighbour pairs (``src`` < ``dst``, numbers of pixels in ``idx``, raster order):
    right, down, down-left and down-right, without the diagonals that a 4-connected corner joins."""
    height, width = skel.shape
    flat = skel.ravel()
    src_parts, dst_parts = [], []
    for dr, dc in ((0, 1), (1, 0), (1, -1), (1, 1)):
        rr, cc = rows + dr, cols + dc
        inside = np.flatnonzero((rr < height) & (cc >= 0) & (cc < width))
        there = rr[inside] * width + cc[inside]
        on = flat[there]
        inside, there = inside[on], there[on]
        if dr and dc:  # a diagonal step is redundant when a 4-connected corner pixel is on the skeleton
            corner = flat[(rows[inside] + dr) * width + cols[inside]] | flat[rows[inside] * width + cols[inside] + dc]
            inside, there = inside[~corner], there[~corner]
        src_parts.append(inside)
        dst_parts.append(np.searchsorted(idx, there))
    return np.concatenate(src_parts), np.concatenate(dst_parts)


def _junction_clusters(junction: np.ndarray, src: np.ndarray, dst: np.ndarray, idx: np.ndarray,
                       dt: np.ndarray | None) -> tuple[int, np.ndarray, np.ndarray]:
    """The clusters of touching junction pixels: how many, each pixel's cluster (-1 off the junctions)
    and each cluster's representative pixel (its largest ``dt``, or its first pixel)."""
    n = junction.size
    cluster = np.full(n, -1, dtype=np.int64)
    jpix = np.flatnonzero(junction)
    if not jpix.size:
        return 0, cluster, np.zeros(0, dtype=np.int64)
    jj = junction[src] & junction[dst]
    jpos = np.full(n, -1, dtype=np.int64)
    jpos[jpix] = np.arange(jpix.size)
    adj = sparse.coo_matrix((np.ones(int(jj.sum()), dtype=np.int8), (jpos[src[jj]], jpos[dst[jj]])),
                            shape=(jpix.size, jpix.size)).tocsr()
    n_junctions, jlabel = csgraph.connected_components(adj, directed=False)
    cluster[jpix] = jlabel
    key = dt.ravel()[idx[jpix]] if dt is not None else -np.arange(jpix.size, dtype=float)
    order = np.lexsort((-key, jlabel))
    first = np.ones(order.size, dtype=bool)
    first[1:] = jlabel[order][1:] != jlabel[order][:-1]
    rep = np.empty(n_junctions, dtype=np.int64)
    rep[jlabel[order][first]] = jpix[order][first]
    return n_junctions, cluster, rep


def _junctions_touched(path: np.ndarray, src: np.ndarray, dst: np.ndarray,
                       cluster: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (up to two) junction clusters each path pixel touches, -1 for none: a path pixel touches
    at most two, and only a one-pixel path two."""
    n = path.size
    pj = path[src] != path[dst]
    a = np.where(path[src[pj]], src[pj], dst[pj])  # the path pixel
    b = cluster[np.where(path[src[pj]], dst[pj], src[pj])]  # the junction it touches
    order = np.lexsort((b, a))
    a, b = a[order], b[order]
    keep = np.ones(a.size, dtype=bool)
    keep[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1])  # one contact per (pixel, junction)
    a, b = a[keep], b[keep]
    first = np.ones(a.size, dtype=bool)
    first[1:] = a[1:] != a[:-1]
    touch1 = np.full(n, -1, dtype=np.int64)
    touch2 = np.full(n, -1, dtype=np.int64)
    touch1[a[first]] = b[first]
    touch2[a[~first]] = b[~first]
    return touch1, touch2


@dataclass(frozen=True, eq=False)
class _Chains:
    """The path pixels as chains in order: chain ``k`` is ``ordered[seg_start[k]:seg_stop[k]]``
    (``counts[k]`` pixels), ``comp_of`` each path pixel's chain, ``ring`` the chains that close."""

    ordered: np.ndarray
    comp_of: np.ndarray
    counts: np.ndarray
    seg_start: np.ndarray
    seg_stop: np.ndarray
    ring: np.ndarray


def _order_chains(ps: np.ndarray, pd: np.ndarray, ppix: np.ndarray, n: int) -> _Chains:
    """The components of the path graph (pixel pairs ``ps``-``pd`` over the path pixels ``ppix``), each
    a chain or a ring, each pixel in order from the chain's start."""
    pdeg = np.bincount(ps, minlength=n) + np.bincount(pd, minlength=n)
    graph = sparse.coo_matrix((np.ones(ps.size, dtype=np.int8), (ps, pd)), shape=(n, n)).tocsr()
    _, comp_all = csgraph.connected_components(graph, directed=False)
    comp_ids, comp = np.unique(comp_all[ppix], return_inverse=True)
    n_comp = comp_ids.size
    # Start of each chain: its first end pixel (pdeg <= 1); a ring starts at its first pixel and is cut there.
    is_end = pdeg[ppix] <= 1
    big = np.iinfo(np.int64).max
    start = np.full(n_comp, big, dtype=np.int64)
    np.minimum.at(start, comp[is_end], ppix[is_end])
    ring = start == big
    if ring.any():
        ring_first = np.full(n_comp, big, dtype=np.int64)
        np.minimum.at(ring_first, comp, ppix)
        start[ring] = ring_first[ring]
        ps, pd = _cut_rings(ps, pd, start[ring], n)
    # One breadth-first search from a virtual root joined to every chain's start orders all chains at once.
    root = n
    bs = np.concatenate([ps, np.full(n_comp, root)])
    bd = np.concatenate([pd, start])
    tree = sparse.coo_matrix((np.ones(bs.size, dtype=np.int8), (bs, bd)), shape=(n + 1, n + 1)).tocsr()
    bfs = csgraph.breadth_first_order(tree, root, directed=False, return_predecessors=False)[1:]
    comp_of = np.empty(n, dtype=np.int64)
    comp_of[ppix] = comp
    ordered = bfs[np.argsort(comp_of[bfs], kind="stable")]
    counts = np.bincount(comp_of[ordered], minlength=n_comp)
    seg_start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return _Chains(ordered, comp_of, counts, seg_start, seg_start + counts, ring)


def _cut_rings(ps: np.ndarray, pd: np.ndarray, ring_starts: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The path pairs without one of each ring start pixel's two pairs, so that each ring is a chain."""
    ring_start = np.zeros(n, dtype=bool)
    ring_start[ring_starts] = True
    cut = ring_start[ps] | ring_start[pd]
    cut_idx = np.flatnonzero(cut)
    owner = np.where(ring_start[ps[cut_idx]], ps[cut_idx], pd[cut_idx])
    _, once = np.unique(owner, return_index=True)
    drop = np.zeros(ps.size, dtype=bool)
    drop[cut_idx[once]] = True
    return ps[~drop], pd[~drop]


@dataclass(frozen=True, eq=False)
class _ChainEnds:
    """The nodes at each chain's ends (``u`` first, ``v`` last), the pixels of the end nodes made for
    them after the junctions (``extra_pixels``), each end's junction pixel (``rep_u``, ``rep_v``; -1
    when the end is not a junction), and ``keep``: the chains that are segments (not lone pixels)."""

    u: np.ndarray
    v: np.ndarray
    extra_pixels: np.ndarray
    rep_u: np.ndarray
    rep_v: np.ndarray
    keep: np.ndarray


def _chain_ends(chains: _Chains, touch1: np.ndarray, touch2: np.ndarray, rep: np.ndarray,
                n_junctions: int) -> _ChainEnds:
    """Each chain's end nodes: a junction the end pixel touches, else a new end node at that pixel."""
    first_px = chains.ordered[chains.seg_start]
    last_px = chains.ordered[chains.seg_stop - 1]
    ring = chains.ring
    u = touch1[first_px].copy()
    single = chains.counts == 1
    v = np.where(single, touch2[first_px], touch1[last_px])
    extra_cells: list[int] = []
    next_node = n_junctions

    def new_nodes(mask: np.ndarray, pixels: np.ndarray) -> np.ndarray:
        nonlocal next_node
        ids = next_node + np.arange(int(mask.sum()))
        next_node += ids.size
        extra_cells.extend(pixels[mask].tolist())
        return ids

    lone = single & (u < 0) & (v < 0)  # an isolated pixel: a node, no segment
    u_free = (u < 0) & ~lone
    u[u_free] = new_nodes(u_free, first_px)
    v_free = (v < 0) & ~lone & ~ring
    v[v_free] = new_nodes(v_free, last_px)
    v[ring] = u[ring]
    u[lone] = new_nodes(lone, first_px)
    return _ChainEnds(u, v, np.asarray(extra_cells, dtype=np.int64), _junction_pixels(u, rep, n_junctions),
                      _junction_pixels(v, rep, n_junctions), ~lone)


def _junction_pixels(nodes: np.ndarray, rep: np.ndarray, n_junctions: int) -> np.ndarray:
    """The representative pixel of each of ``nodes`` that is a junction, -1 for the others."""
    pixels = np.full(nodes.size, -1, dtype=np.int64)
    at_junction = (nodes >= 0) & (nodes < n_junctions)
    pixels[at_junction] = rep[nodes[at_junction]]
    return pixels


def _chain_lengths(chains: _Chains, ends: _ChainEnds, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Each chain's length in cells, node to node: the steps along it plus the jumps to its junction
    pixels (and the step that closes a ring)."""
    ordered, comp_of, seg_start, seg_stop, ring = (chains.ordered, chains.comp_of, chains.seg_start,
                                                   chains.seg_stop, chains.ring)
    rep_u, rep_v = ends.rep_u, ends.rep_v
    pr, pc = rows[ordered].astype(float), cols[ordered].astype(float)
    step = np.hypot(np.diff(pr), np.diff(pc))
    length = np.zeros(chains.counts.size)
    inner = np.ones(step.size, dtype=bool)
    inner[seg_stop[:-1] - 1] = False  # the step from one chain to the next is not a step
    np.add.at(length, comp_of[ordered[:-1]][inner], step[inner])
    has_u = rep_u >= 0
    length[has_u] += np.hypot(rows[rep_u[has_u]] - pr[seg_start[has_u]], cols[rep_u[has_u]] - pc[seg_start[has_u]])
    has_v = rep_v >= 0
    last = seg_stop - 1
    length[has_v] += np.hypot(rows[rep_v[has_v]] - pr[last[has_v]], cols[rep_v[has_v]] - pc[last[has_v]])
    if ring.any():  # close the ring
        length[ring] += np.hypot(pr[seg_start[ring]] - pr[last[ring]], pc[seg_start[ring]] - pc[last[ring]])
    return length


# -- support and costs ---------------------------------------------------------------

def _disk_offsets(radius_cells: float) -> np.ndarray:
    r = max(0, int(math.floor(radius_cells)))
    span = np.arange(-r, r + 1)
    dr, dc = np.meshgrid(span, span, indexing="ij")
    inside = dr * dr + dc * dc <= radius_cells * radius_cells
    return np.column_stack([dr[inside], dc[inside]])


def cell_support(p_occ: np.ndarray, cells: np.ndarray, band_cells: float) -> np.ndarray:
    """Probability that the band around each cell is empty: min of 1 - P(occ) over a disc of ``band_cells``.

    NaN (unknown) counts as 1 - 0.5; cells beyond the grid are skipped.
    Computed only at ``cells`` ((N, 2) row, col), one gather per disc offset.
    """
    p = np.asarray(p_occ)
    height, width = p.shape
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    flat = p.ravel()
    offsets = _disk_offsets(band_cells)
    worst = np.zeros(len(cells), dtype=flat.dtype if flat.dtype.kind == "f" else float)  # highest P(occ) seen
    unknown = np.zeros(len(cells), dtype=bool)
    if not len(cells):
        return np.ones(0)
    k = int(np.abs(offsets).max())
    base = cells[:, 0] * width + cells[:, 1]
    clear = (cells[:, 0].min() >= k and cells[:, 0].max() < height - k and cells[:, 1].min() >= k
             and cells[:, 1].max() < width - k)
    for dr, dc in offsets:
        if clear:  # the usual case (skeleton cells keep the band's clearance): no bounds to check
            values = flat[base + (dr * width + dc)]
        else:
            r, c = cells[:, 0] + dr, cells[:, 1] + dc
            inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            values = np.where(inside, flat[np.where(inside, r * width + c, 0)], 0.0)
        np.fmax(worst, values, out=worst)  # fmax skips NaN
        unknown |= np.isnan(values)
    best = 1.0 - worst.astype(float)
    best[unknown] = np.minimum(best[unknown], UNKNOWN_SUPPORT)
    return np.clip(best, MIN_PROBABILITY, 1.0)


def segment_costs(support: np.ndarray, cells: np.ndarray, offsets: np.ndarray, resolution: float,
                  diameter: float) -> tuple[np.ndarray, np.ndarray]:
    """(length in metres, cost) of paths laid end to end in ``cells`` (split at ``offsets``, which ends with len).

    A cell's weight is half of its steps to its neighbours on the path (so
    a node cell counts half in each of two edges); ``cost = sum -log(p_i)
    w_i / diameter`` and ``probability = exp(-cost)``.
    """
    cells = np.asarray(cells, dtype=float).reshape(-1, 2)
    starts = np.asarray(offsets[:-1], dtype=np.int64)
    stops = np.asarray(offsets[1:], dtype=np.int64)
    if cells.shape[0] == 0:
        return np.zeros(starts.size), np.zeros(starts.size)
    step = np.hypot(*np.diff(cells, axis=0).T) * resolution
    inner = np.ones(step.size, dtype=bool)
    inner[stops[:-1] - 1] = False  # no step between paths
    step = np.where(inner, step, 0.0)
    weight = np.zeros(cells.shape[0])
    weight[:-1] += step / 2
    weight[1:] += step / 2
    which = np.repeat(np.arange(starts.size), stops - starts)
    length = np.bincount(which[:-1], weights=step, minlength=starts.size)
    cost = np.bincount(which, weights=-np.log(support) * weight, minlength=starts.size) / diameter
    return length, np.maximum(cost, 0.0)


# -- the whole pipeline ---------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class SkeletonSegment:
    """A segment of the stochastic SDT: the skeleton between two nodes, with its probability of being empty.

    ``cells`` (n, 2) are (row, col) from node ``u`` to node ``v``;
    ``length`` in metres; ``probability`` that it is empty; ``cost`` =
    -log(probability).
    """

    u: int
    v: int
    cells: np.ndarray
    length: float
    probability: float
    cost: float


@dataclass(frozen=True, eq=False)
class SDT:
    """The skeletonized distance transform: DT (metres), skeleton (bool), stochastic segments, places (int labels).

    ``segments`` are the skeleton after pruning and merging, i.e. the
    topology's edges, each with its probability of being empty.
    """

    dt: np.ndarray
    skeleton: np.ndarray
    segments: tuple[SkeletonSegment, ...]
    places: np.ndarray

    def probability_grid(self) -> np.ndarray:
        """Each segment's probability on its cells, NaN elsewhere (for ``render_stochastic_sdt``)."""
        grid = np.full(self.dt.shape, np.nan, dtype=np.float32)
        for seg in sorted(self.segments, key=lambda s: -s.probability):  # the weakest segment wins a shared cell
            grid[seg.cells[:, 0], seg.cells[:, 1]] = seg.probability
        return grid
