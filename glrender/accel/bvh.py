"""``build_bvh``: triangles in, a wide BVH packed for the GLSL traversal out.

Pipeline (all numpy, no GL): validate and clean the triangles
(:mod:`.mesh`), build a binary tree (by default PLOC up to 4096 clusters and a
binned SAH over those for the top, :mod:`.ploc`; a full binned-SAH sweep on
request, :mod:`.binned_sah`), choose leaves of at most four triangles by SAH
(up to seven on request for 8-wide trees), collapse to ``width`` = 4 (the
default) or 8 children per node with a bounded depth (:mod:`.collapse`) and
reorder the triangles so that every leaf is a contiguous range. Rigid motion
instances (:mod:`.instances`) get their own trees, of the same width, in the
same buffers; so do the prototypes of static instances, followed by a top-level
tree over the instances (``instanced``).

The packed layout (:meth:`Bvh.pack`) is what ``shaders/geometry/bvh.glsl``
reads through buffer textures (it reads 4-wide trees):

``nodes`` (rgba32ui, :mod:`.quantize`: 4 texels = 64 bytes per 4-wide node, 6 = 96 bytes per 8-wide one)
    the node's origin and scale, the child references and the child
    boxes as 8-bit planes rounded outwards. A reference is an inner node index
    (high bit clear) or a leaf ``LEAF_FLAG | count << 28 | first`` covering
    triangles ``[first, first + count)`` (count in 3 bits: at most 7); empty
    slots decode to a box no ray enters.
``triangles`` (rgba32f, 3 texels per triangle)
    the corners v0, v1, v2 of each triangle in BVH order (``w`` unused).
``instances`` (rgba32f)
    a header (motion instances, static triangles, static instances, top-level root),
    the motion instances (``shaders/geometry/motion.glsl``), then the static instances
    in the top-level tree's leaf order (``shaders/geometry/instances.glsl``).
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from .binned_sah import build_binned_sah
from .collapse import (DEFAULT_WIDTH, KIND_EMPTY, KIND_INNER, KIND_LEAF, MAX_LEAF_SIZE, WIDTHS, BvhArrays,
                       collapse_to_bvh)
from .instances import (MAX_MOTION_INSTANCES, MotionInstance, StaticInstances, instance_world_bounds,
                        motion_bounds, pack_instance, pack_static_instances)
from .mesh import PreparedTriangles, prepare_triangles
from .ploc import DEFAULT_RADIUS, DEFAULT_TOP_CLUSTERS, build_ploc
from .quantize import pack_nodes
from .tree import BinaryTree, half_area

METHODS = ("ploc", "binned_sah")
# The version of what build_bvh and Bvh.pack output for given input and parameters. The BVH
# cache (accel/bvh_cache.py) keys its entries by it: bump it with any change to the builder,
# its stages (mesh clean-up, PLOC, binned SAH, leaf decisions, collapse, quantisation) or
# the packed layout that changes a single output bit, or caches will serve the old trees.
BUILDER_VERSION = 1
LEAF_FLAG = 0x80000000
LEAF_COUNT_SHIFT = 28
LEAF_FIRST_MASK = (1 << LEAF_COUNT_SHIFT) - 1
EMPTY_REF = LEAF_FLAG  # a leaf of zero triangles: harmless even if visited
# Stack bound of a traversal: it pushes at most width - 1 entries per inner node
# on the path, so a tree of inner depth <= max_depth(width) never needs more than
# stack_size(width) = (width - 1) * (max_depth(width) + 1) entries (4-wide: 96,
# 8-wide: 154); the builder guarantees the depth.
MAX_DEPTH_BY_WIDTH = {4: 31, 8: 21}
# The 4-wide bound, which shaders/geometry/bvh.glsl sizes its stack from
# (kBvhStackSize; common/params.glsl GLRENDER_BVH_MAX_DEPTH).
MAX_DEPTH = MAX_DEPTH_BY_WIDTH[4]
# Largest leaf per width: the reference's 3-bit count holds 7; 4-wide trees keep 4.
MAX_LEAF_SIZE_BY_WIDTH = {4: 4, 8: 7}
# SAH constants for the leaf decision (cost of a binary node visit and of a
# triangle test, in the same unit). Triangle costs 0.5..1.5 traced within 3% of
# each other (mean leaf 2.8..1.7 triangles); benchmarks/RESULTS.md, "BVH".
C_NODE = 1.0
C_TRI = 1.0


def max_depth(width: int) -> int:
    """Deepest inner node (the root is 0) a ``width``-wide tree may have: 31 for 4, 21 for 8."""
    return MAX_DEPTH_BY_WIDTH[width]


def stack_size(width: int) -> int:
    """Traversal stack entries that a ``width``-wide tree of depth <= max_depth(width) can need."""
    return (width - 1) * (max_depth(width) + 1)


@dataclass
class MotionBvh:
    """A motion instance's own tree (object space) and its world box over the shutter."""

    instance: MotionInstance
    bvh: Bvh
    world_lo: np.ndarray
    world_hi: np.ndarray


@dataclass
class TopLevel:
    """The top-level tree over static instances: its wide tree (one instance per leaf),
    ``order`` (leaf order -> instance index) and the instances' world boxes."""

    instanced: StaticInstances
    arrays: BvhArrays
    order: np.ndarray
    world_lo: np.ndarray
    world_hi: np.ndarray


@dataclass
class BvhBuffers:
    """What rendering needs of a built BVH (all of it cacheable, :mod:`.bvh_cache`): the
    packed buffers of :meth:`Bvh.pack`, the ``prim_order`` of the static tree, then of
    each motion instance's tree, then of each static prototype's tree, the width and depth,
    and :meth:`Bvh.stats`."""

    packed: dict[str, np.ndarray]
    prim_orders: list[np.ndarray]
    width: int
    depth: int
    build_stats: dict

    def pack(self) -> dict[str, np.ndarray]:
        """The packed buffers, as :meth:`Bvh.pack` (what :class:`~glrender.gpu.bvh_upload.GpuBvh`
        uploads)."""
        return self.packed

    @property
    def prim_order(self) -> np.ndarray:
        """The static tree's BVH-order triangle -> input triangle index."""
        return self.prim_orders[0]


@dataclass
class Bvh:
    """A 4- or 8-wide BVH over triangles, in BVH order (see the module doc for the layout)."""

    corners: np.ndarray  # (T, 3, 3) float32, BVH order
    prim_order: np.ndarray  # (T,) int64: BVH-order triangle -> input triangle index
    arrays: BvhArrays
    prepared: PreparedTriangles = field(repr=False)
    method: str = "ploc"
    build_seconds: float = 0.0
    binary_sah: float = 0.0
    motion: list[MotionBvh] = field(default_factory=list)
    prototypes: list[Bvh] = field(default_factory=list)   # static instances' bottom-level trees
    top: TopLevel | None = None
    _packed: dict | None = field(default=None, repr=False)

    @property
    def triangle_count(self) -> int:
        return len(self.corners)

    @property
    def node_count(self) -> int:
        return self.arrays.node_count

    @property
    def width(self) -> int:
        """Children per node: 4 or 8 (motion instances' trees have the same)."""
        return self.arrays.width

    @property
    def depth(self) -> int:
        """Depth of the deepest inner node (the root is 0), motion instances' trees included."""
        own = int(self.arrays.depth.max()) if self.node_count else 0
        top = int(self.top.arrays.depth.max()) if self.top is not None else 0
        return max([own, top] + [m.bvh.depth for m in self.motion] + [p.depth for p in self.prototypes])

    def motion_prim_ranges(self) -> list[tuple[int, int]]:
        """[begin, end) of each motion instance's triangles in the packed (BVH-order) ids.

        Hits with ``prim < triangle_count`` are static triangles (``prim_order``
        maps them to input indices); instance k's hit ``prim`` is its triangle
        ``motion[k].bvh.prim_order[prim - begin]``.
        """
        ranges, begin = [], self.triangle_count
        for m in self.motion:
            ranges.append((begin, begin + m.bvh.triangle_count))
            begin += m.bvh.triangle_count
        return ranges

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World box of all triangles (an inverted box when empty)."""
        if not self.triangle_count:
            return np.full(3, np.inf, np.float32), np.full(3, -np.inf, np.float32)
        c = self.corners
        return (np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2]).min(axis=0),
                np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2]).max(axis=0))

    def sah_cost(self, c_node: float = 1.0, c_tri: float = 1.0) -> float:
        """SAH cost of the wide tree relative to its root box.

        ``(c_node * sum of inner node areas + c_tri * sum of leaf area x count) / root area``
        (Goldsmith & Salmon 1987; MacDonald & Booth 1990), with surface areas of
        the node boxes; one inner node visit tests all its child boxes.
        """
        a = self.arrays
        if not self.triangle_count:
            return 0.0
        lo, hi = a.child_lo, a.child_hi
        area = half_area(lo.astype(np.float64), hi.astype(np.float64))  # empty slots: 0
        root_lo, root_hi = self.bounds
        root_area = float(half_area(root_lo.astype(np.float64), root_hi.astype(np.float64)))
        inner = area[a.child_kind == KIND_INNER].sum() + root_area
        leaves = (area * a.child_count)[a.child_kind == KIND_LEAF].sum()
        if root_area <= 0:
            return float(c_node + c_tri * self.triangle_count)
        return float((c_node * inner + c_tri * leaves) / root_area)

    @property
    def nbytes(self) -> int:
        """Bytes of the packed buffers (nodes, triangles, motion instances)."""
        return sum(v.nbytes for v in self.pack().values())

    def stats(self) -> dict:
        """Build statistics: counts, removed triangles, depth, SAH, memory."""
        a = self.arrays
        leaf = a.child_kind == KIND_LEAF
        leaves = int(np.count_nonzero(leaf))
        p = self.prepared
        nbytes = self.nbytes
        return {
            "method": self.method,
            "width": self.width,
            "input_triangles": p.input_count,
            "triangles": self.triangle_count,
            "skipped_invalid": p.skipped_invalid,
            "skipped_degenerate": p.skipped_degenerate,
            "removed_duplicates": p.removed_duplicates,
            "nodes": self.node_count,
            "leaves": leaves,
            "mean_leaf_size": float(a.child_count[leaf].mean()) if leaves else 0.0,
            "depth": self.depth,
            "sah_cost": self.sah_cost(),
            "binary_sah_cost": self.binary_sah,
            "motion_instances": len(self.motion),
            "motion_triangles": sum(m.bvh.triangle_count for m in self.motion),
            "static_instances": len(self.top.order) if self.top is not None else 0,
            "prototype_triangles": sum(p.triangle_count for p in self.prototypes),
            "instanced_triangles": self.instanced_triangles,
            "bytes": nbytes,
            "bytes_per_triangle": nbytes / max(self.triangle_count + sum(
                m.bvh.triangle_count for m in self.motion) + self.instanced_triangles, 1),
            "build_seconds": self.build_seconds,
        }

    def buffers(self) -> BvhBuffers:
        """The packed buffers, triangle orders and statistics (:class:`BvhBuffers`)."""
        return BvhBuffers(self.pack(), [self.prim_order] + [m.bvh.prim_order for m in self.motion]
                          + [p.prim_order for p in self.prototypes], self.width, self.depth, self.stats())

    @property
    def instanced_triangles(self) -> int:
        """Triangles the static instances place (each copy counted)."""
        if self.top is None:
            return 0
        counts = np.array([p.triangle_count for p in self.prototypes], np.int64)
        return int(counts[self.top.instanced.prototype[self.top.order]].sum())

    def child_refs(self, node_offset: int = 0, triangle_offset: int = 0) -> np.ndarray:
        """(N, width) uint32 child references (see the module doc), for a tree stored
        ``node_offset`` nodes and ``triangle_offset`` triangles into the buffers."""
        return _child_refs(self.arrays, node_offset, triangle_offset)

    def pack(self) -> dict[str, np.ndarray]:
        """The arrays of the buffer textures: ``nodes`` (uint32), ``triangles`` and
        ``instances`` (float32). Motion instances' trees follow the static one."""
        if self._packed is None:
            trees = [self] + [m.bvh for m in self.motion] + self.prototypes
            nodes, tris, records, roots = [], [], [], []
            node_base, tri_base = 0, 0
            for k, tree in enumerate(trees):
                a = tree.arrays
                nodes.append(pack_nodes(a.child_lo, a.child_hi, a.child_kind != KIND_EMPTY,
                                        tree.child_refs(node_base, tri_base)))
                t = np.zeros((tree.triangle_count, 3, 4), np.float32)
                t[..., :3] = tree.corners
                tris.append(t.reshape(-1, 4))
                if 0 < k <= len(self.motion):
                    m = self.motion[k - 1]
                    records.append(pack_instance(m.instance, node_base, tri_base,
                                                 tri_base + tree.triangle_count, m.world_lo, m.world_hi))
                elif k > len(self.motion):
                    roots.append(node_base)
                node_base += tree.node_count
                tri_base += tree.triangle_count
            header = np.zeros((1, 4), np.float32)
            top = self.top
            header[0] = np.array([len(self.motion), self.triangle_count,
                                  len(top.order) if top is not None else 0,
                                  node_base if top is not None else 0], np.uint32).view(np.float32)
            if top is not None:
                a = top.arrays
                nodes.append(pack_nodes(a.child_lo, a.child_hi, a.child_kind != KIND_EMPTY,
                                        _child_refs(a, node_base, 0)))
                proto = top.instanced.prototype[top.order]
                records.append(pack_static_instances(top.instanced.transforms[top.order],
                                                     np.asarray(roots, np.int64)[proto]))
            self._packed = {"nodes": np.concatenate(nodes), "triangles": np.concatenate(tris),
                            "instances": np.concatenate([header] + records)}
        return self._packed


def build_bvh(vertices, triangles, *, method: str = "ploc", radius: int = DEFAULT_RADIUS,
              top_clusters: int = DEFAULT_TOP_CLUSTERS, threads: int | None = None,
              on_invalid: str = "skip", remove_degenerate: bool = True,
              remove_duplicates: bool = True, max_leaf_size: int = MAX_LEAF_SIZE,
              c_node: float = C_NODE, c_tri: float = C_TRI, motion=(), width: int = DEFAULT_WIDTH,
              instanced: StaticInstances | None = None) -> Bvh:
    """Build a ``width``-wide BVH over ``triangles`` (T, 3) int indexing ``vertices`` (V, 3).

    ``method``: ``"ploc"`` (fast, the default) or ``"binned_sah"`` (a full
    top-down binned SAH sweep: slower, the quality reference). ``on_invalid``:
    ``"skip"`` or ``"raise"`` for triangles with NaN/Inf vertices. Zero-area and
    exactly duplicated triangles are dropped (counted in :meth:`Bvh.stats`)
    unless disabled. ``prim_order`` maps BVH-order triangles to input indices.
    ``motion``: :class:`~glrender.accel.instances.MotionInstance` objects, each
    built into its own tree (see :meth:`Bvh.motion_prim_ranges`). ``instanced``:
    :class:`~glrender.accel.instances.StaticInstances`, a tree per prototype and a
    top-level tree over the instances (instances of an empty prototype are left out).
    ``width``: 4 children per node (what the GLSL traversal reads) or 8;
    ``max_leaf_size`` at most 4 for width 4 and 7 for width 8.
    """
    if method not in METHODS:
        raise UsageError(f"build_bvh: method must be one of {METHODS}, got {method!r}")
    if isinstance(width, bool) or width not in WIDTHS:
        raise UsageError(f"build_bvh: width must be one of {WIDTHS}, got {width!r}")
    width = int(width)
    limit = MAX_LEAF_SIZE_BY_WIDTH[width]
    if not 1 <= max_leaf_size <= limit:
        raise UsageError(f"build_bvh: max_leaf_size must be 1..{limit} for width {width}, "
                         f"got {max_leaf_size}")
    start = time.perf_counter()
    prepared = prepare_triangles(vertices, triangles, on_invalid=on_invalid,
                                 remove_degenerate=remove_degenerate,
                                 remove_duplicates=remove_duplicates)
    c = prepared.corners
    lo = np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2])
    hi = np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2])
    threads = threads or build_threads()
    tree = build_ploc(lo, hi, radius, top_clusters, threads) if method == "ploc" else build_binned_sah(lo, hi)
    arrays = collapse_tree(tree, max_leaf_size, c_node, c_tri, width)
    order = arrays.prim_order
    bvh = Bvh(np.take(c, order, axis=0), np.take(prepared.source, order), arrays, prepared, method,
              binary_sah=tree.sah_cost())
    if len(motion) > MAX_MOTION_INSTANCES:
        raise UsageError(f"build_bvh: at most {MAX_MOTION_INSTANCES} motion instances "
                         f"(every ray tests each one), got {len(motion)}")
    for k, instance in enumerate(motion):
        if not isinstance(instance, MotionInstance):
            raise UsageError(f"build_bvh: motion[{k}] is not a MotionInstance")
        tree = build_bvh(instance.vertices, instance.triangles, method=method, radius=radius,
                         top_clusters=top_clusters, threads=threads, on_invalid=on_invalid,
                         remove_degenerate=remove_degenerate, remove_duplicates=remove_duplicates,
                         max_leaf_size=max_leaf_size, c_node=c_node, c_tri=c_tri, width=width)
        lo, hi = tree.bounds
        if tree.triangle_count:
            lo, hi = motion_bounds(instance, lo, hi)
        bvh.motion.append(MotionBvh(instance, tree, lo, hi))
    if instanced is not None and len(instanced):
        if not isinstance(instanced, StaticInstances):
            raise UsageError("build_bvh: instanced is not a StaticInstances")
        options = dict(method=method, radius=radius, top_clusters=top_clusters, threads=threads,
                       on_invalid=on_invalid, remove_degenerate=remove_degenerate,
                       remove_duplicates=remove_duplicates, max_leaf_size=max_leaf_size,
                       c_node=c_node, c_tri=c_tri, width=width)
        bvh.prototypes = [build_bvh(v, f, **options) for v, f in instanced.prototypes]
        bvh.top = _top_level(instanced, bvh.prototypes, method, radius, top_clusters, threads, width)
    bvh.build_seconds = time.perf_counter() - start
    return bvh


def _top_level(instanced: StaticInstances, prototypes: list[Bvh], method: str, radius: int,
               top_clusters: int, threads: int, width: int) -> TopLevel | None:
    """The top-level tree over the instances of non-empty prototypes (None: none)."""
    lo = np.zeros((len(instanced), 3), np.float32)
    hi = np.zeros((len(instanced), 3), np.float32)
    keep = np.zeros(len(instanced), bool)
    for k, proto in enumerate(prototypes):
        mine = np.flatnonzero(instanced.prototype == k)
        if proto.triangle_count and len(mine):
            lo[mine], hi[mine] = instance_world_bounds(instanced.transforms[mine], *proto.bounds)
            keep[mine] = True
    index = np.flatnonzero(keep)
    if not len(index):
        return None
    lo, hi = lo[index], hi[index]
    tree = build_ploc(lo, hi, radius, top_clusters, threads) if method == "ploc" else build_binned_sah(lo, hi)
    # one instance per leaf: a leaf costs a ray transform and a bottom-level traversal
    arrays = collapse_tree(tree, 1, C_NODE, C_TRI, width)
    return TopLevel(instanced, arrays, index[arrays.prim_order], lo, hi)


def _child_refs(a: BvhArrays, node_offset: int, first_offset: int) -> np.ndarray:
    """(N, width) uint32 child references of tree ``a`` (see the module doc), stored
    ``node_offset`` nodes into the node buffer, leaves ``first_offset`` into their items."""
    refs = np.full(a.child_kind.shape, EMPTY_REF, np.uint64)
    inner = a.child_kind == KIND_INNER
    leaf = a.child_kind == KIND_LEAF
    refs[inner] = (a.child_index[inner] + node_offset).astype(np.uint64)
    first = a.child_index[leaf] + first_offset
    if len(first) and first.max() + MAX_LEAF_SIZE_BY_WIDTH[a.width] > LEAF_FIRST_MASK:
        raise UsageError(f"too many triangles for a leaf reference (at most {LEAF_FIRST_MASK})")
    refs[leaf] = (LEAF_FLAG | (a.child_count[leaf] << LEAF_COUNT_SHIFT) | first).astype(np.uint64)
    return refs.astype(np.uint32)


def build_threads() -> int:
    """Threads for the parallel parts of a build: the usable cores."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def collapse_tree(tree: BinaryTree, max_leaf_size: int = MAX_LEAF_SIZE, c_node: float = C_NODE,
                  c_tri: float = C_TRI, width: int = DEFAULT_WIDTH) -> BvhArrays:
    """Leaf decisions by SAH, then the collapse to ``width`` children per node."""
    count = tree.counts()
    leaf = tree.leaf_mask(count, max_leaf_size, c_node, c_tri)
    return collapse_to_bvh(tree, leaf, count, tree.first_prim(count), max_depth(width), width)
