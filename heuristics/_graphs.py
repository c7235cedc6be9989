"""Hop distances and the exact diameter of a connected network's adjacency.

:func:`diameter` is what :attr:`heuristics.network.Network.diameter` runs for the drawn
topologies; :func:`reference_diameter` is the plain Takes-Kosters extrema bounding it
replaced, kept as the reference the tests compare it with.  Both are exact: every
answer is an eccentricity some breadth-first search measured, certified as the largest
by bounds that follow from the triangle inequality.

>>> import numpy as np
>>> from scipy.sparse import csr_array
>>> ring = csr_array((np.ones(12, np.int8), ([0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 0],
...                   [1, 0, 2, 1, 3, 2, 4, 3, 5, 4, 0, 5])), shape=(6, 6))
>>> bfs_distances(ring, 0).tolist(), diameter(ring), reference_diameter(ring)
([0, 1, 2, 3, 2, 1], 3, 3)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_array
from scipy.sparse.csgraph import breadth_first_order

__all__ = ["PAIR_BUDGET", "bfs_distances", "diameter", "reference_diameter"]

#: At most this many (robot, robot) pairs are kept as "maybe farther apart than the
#: best eccentricity so far" (16 bytes each); past it a robot waits for its own search.
PAIR_BUDGET = 4_000_000
#: A robot gets a pair list only when it would hold at most this many robots.
_FAR_SET_CAP = 512

Ints = npt.NDArray[np.int64]
Mask = npt.NDArray[np.bool_]


def bfs_distances(graph: csr_array, source: int) -> Ints:
    """Hop distances from ``source`` in a connected graph (int64, shape (n,)).

    One breadth-first search in scipy, then the depths of its tree by pointer jumping
    (O(n log depth) in numpy): O(n log n + edges) in all.
    """
    n = graph.shape[0]
    _, parents = breadth_first_order(graph, source, directed=True, return_predecessors=True)
    ancestor = parents.astype(np.int64)
    ancestor[source] = source
    depth = np.ones(n, dtype=np.int64)
    depth[source] = 0
    while True:
        further = ancestor[ancestor]
        if np.array_equal(further, ancestor):
            return depth
        depth += depth[ancestor]
        ancestor = further


def reference_diameter(graph: csr_array) -> int:
    """Takes and Kosters' extrema bounding (as in ``nx.diameter(usebounds=True)``).

    Keeps a lower and an upper bound of every robot's eccentricity, refines them from
    one breadth-first search at a time (alternately from the robot with the largest
    upper bound and the one with the smallest lower bound), and stops when no robot's
    upper bound exceeds the largest eccentricity found.  Usually a handful of searches;
    n of them (O(n (n + edges))) on graphs such as rings where every robot is peripheral.
    """
    n = graph.shape[0]
    lower = np.zeros(n, dtype=np.int64)
    upper = np.full(n, n, dtype=np.int64)
    unvisited = np.ones(n, dtype=bool)
    best = 0
    source, from_high = 0, True
    while True:
        dist = bfs_distances(graph, source)
        eccentricity = int(dist.max())
        unvisited[source] = False
        best = max(best, eccentricity)
        np.maximum(lower, np.maximum(dist, eccentricity - dist), out=lower)
        np.minimum(upper, eccentricity + dist, out=upper)
        exact = unvisited & (lower == upper)
        if exact.any():
            best = max(best, int(lower[exact].max()))
        candidates = unvisited & (upper > best) & ~exact
        if not candidates.any():
            return best
        if from_high:
            source = int(np.argmax(np.where(candidates, upper, -1)))
        else:
            source = int(np.argmin(np.where(unvisited & ~exact, lower, n + 1)))
        from_high = not from_high


class _Bounds:
    """What the searches so far prove about every robot's eccentricity.

    ``best`` is the largest proven lower bound of an eccentricity (so ``best <= d_G``);
    a robot is *settled* once its eccentricity is proven ``<= best``.  Proofs: the
    extrema bounds ``max(d, e - d) <= ecc(v) <= e + d`` of each search (from a robot of
    eccentricity ``e`` at distance ``d``), and pair lists: robot v's list holds every
    robot y not yet proven within ``best`` of v (``d_s(v) + d_s(y) <= best`` for some
    search s, or y settled, is such a proof), so an empty list settles v.  A robot
    gets its list from a search that ends few robots beyond ``best - d_s(v)`` hops.
    """

    def __init__(self, graph: csr_array) -> None:
        n = graph.shape[0]
        self.graph, self.n = graph, n
        self.lower = np.zeros(n, dtype=np.int64)
        self.upper = np.full(n, n, dtype=np.int64)
        self.listed = np.zeros(n, dtype=bool)  # has a pair list (possibly empty)
        self.searched = np.zeros(n, dtype=bool)
        self.settled = np.zeros(n, dtype=bool)
        self.near = np.empty(0, dtype=np.int64)  # pair lists: (near[k], far[k])
        self.far = np.empty(0, dtype=np.int64)
        self.best = 0

    def search(self, source: int) -> None:
        """One breadth-first search from ``source`` and everything it proves."""
        dist = bfs_distances(self.graph, source)
        eccentricity = int(dist.max())
        self.searched[source] = True
        np.maximum(self.lower, np.maximum(dist, eccentricity - dist), out=self.lower)
        np.minimum(self.upper, eccentricity + dist, out=self.upper)
        self.best = max(self.best, int(self.lower.max()))
        self.settled |= self.upper <= self.best
        self._filter_pairs(dist)
        self._list_pairs(dist, eccentricity)
        holding = np.zeros(self.n, dtype=bool)
        holding[self.near] = True
        self.settled |= self.listed & ~holding

    def _filter_pairs(self, dist: Ints) -> None:
        near, far = self.near, self.far
        keep = (dist[near] + dist[far] > self.best) & ~self.settled[near] & ~self.settled[far]
        self.near, self.far = near[keep], far[keep]

    def _list_pairs(self, dist: Ints, eccentricity: int) -> None:
        """Pair lists for the unlisted, unsettled robots this search can give one."""
        waiting = ~self.settled & ~self.listed
        if not waiting.any():
            return
        beyond = np.cumsum(np.bincount(dist, minlength=eccentricity + 1)[::-1])[::-1]
        for hops in range(1, eccentricity + 1):
            threshold = self.best - hops + 1  # the robots y with d(y) >= threshold
            if threshold > eccentricity:  # none: an empty list
                self.listed |= waiting & (dist == hops)
                continue
            robots = np.flatnonzero(waiting & (dist == hops))
            size = int(beyond[max(threshold, 0)])
            if size > _FAR_SET_CAP or len(self.near) + size * len(robots) > PAIR_BUDGET:
                return
            ys = np.flatnonzero((dist >= threshold) & ~self.settled)
            near, far = np.repeat(robots, len(ys)), np.tile(ys, len(robots))
            distinct = near != far
            self.near = np.concatenate([self.near, near[distinct]])
            self.far = np.concatenate([self.far, far[distinct]])
            self.listed[robots] = True

    def open(self) -> Mask:
        return ~self.settled

    def by_largest_upper(self) -> int | None:
        return _pick(np.where(self.open(), self.upper, -1), self.searched)

    def by_smallest_lower(self) -> int | None:
        return _pick(np.where(self.open(), self.n + 1 - self.lower, -1), self.searched)

    def by_cover(self) -> int | None:
        """The robot with the most unlisted, unsettled robots in its closed neighbourhood
        (a search from it gives each of them a pair list, or settles them)."""
        waiting = (self.open() & ~self.listed).astype(np.float64)
        if not waiting.any():
            return None
        return _pick(self.graph @ waiting + waiting, self.searched)

    def by_far_count(self) -> int | None:
        """The robot in the most pair lists (a search from it answers all of them)."""
        if not len(self.far):
            return None
        return _pick(np.bincount(self.far, minlength=self.n).astype(np.float64), self.searched)


def _pick(score: npt.NDArray[np.floating | np.integer], searched: Mask) -> int | None:
    """The unsearched robot of the highest positive score (lowest index first)."""
    score = np.where(searched, -1, score)
    best = int(np.argmax(score))
    return best if score[best] > 0 else None


def diameter(graph: csr_array) -> int:
    """The exact diameter of a connected graph (0 for fewer than two robots).

    Breadth-first searches from robots chosen in turn by four rules: the largest
    eccentricity upper bound and the smallest lower bound (Takes and Kosters' extrema
    bounding, which settles graphs with a spread of eccentricities in a handful of
    searches), the robot whose neighbourhood holds the most robots without a pair list,
    and the robot in the most pair lists (which settle expander-like graphs, such as
    G(n, p), where nearly every robot is within one hop of the diameter and only a few
    pairs are at the diameter).  Each search costs O(n log n + edges); the number of
    searches is small on graphs with peripheral fringes (geometric, grids, trees) and
    about a dominating set (order n / degree) on G(n, p).
    """
    n = graph.shape[0]
    if n <= 1:
        return 0
    bounds = _Bounds(graph)
    rules = (
        bounds.by_largest_upper,
        bounds.by_cover,
        bounds.by_far_count,
        bounds.by_smallest_lower,
    )
    source: int | None = int(np.argmax(np.diff(graph.indptr)))
    turn = 0
    while source is not None:
        bounds.search(source)
        if bounds.settled.all():
            break
        source = None
        for offset in range(len(rules)):
            source = rules[(turn + offset) % len(rules)]()
            if source is not None:
                turn = (turn + offset + 1) % len(rules)
                break
    return bounds.best
