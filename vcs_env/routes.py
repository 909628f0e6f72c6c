"""The route layer shared by every planner: a visibility graph over the walls grown by the robot
radius gives each robot its next visible waypoint.

Walls are segments (:mod:`vcs_env.walls`); a robot of radius ``r`` fits wherever its centre
stays at least ``r`` from every segment (outside every *capsule*). The roadmap's nodes sit around
each segment end point, on a circle of radius ``rho = (r + MARGIN) / cos(pi / 8)`` (those of
eight directions that point beyond the end, and the two at 3 pi / 8 from the wall's own outward
direction, which keep ``r + MARGIN`` from its line whatever its angle; kept where they are clear
of the capsules): the
chord between two neighbouring nodes keeps ``r + MARGIN`` from the end point, so a route can turn around a wall end. Two
points *see* each other when the segment between them keeps at least ``r`` from every wall.
A goal's cost-to-go is Dijkstra over the visibility edges; a robot's next waypoint is its goal
if it sees it, else the visible node that minimizes ``|p - node| + cost(node)`` (the first
corner of the shortest route through the roadmap).

Without walls the waypoint is the goal and nothing here runs: planners are unchanged.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from .kernels import _closest_approach, _segment_distance
from .state import WorldState
from .walls import clearance

MARGIN = 0.15
"""Clearance beyond the robot radius of the roadmap's nodes [m]; the lines of sight between
them keep half of it (room for a unicycle's turn), a door one robot diameter plus 0.2 m wide
still holds nodes."""
_DIRECTIONS = 8


@njit(cache=True)
def _clear_line(px, py, qx, qy, seg, r):
    """The segment from ``p`` to ``q`` keeps >= ``r`` [m] from every wall segment ``seg`` ``(s, 2, 2)``."""
    ux, uy = qx - px, qy - py
    reach = (r + 1e-9) * math.sqrt(ux * ux + uy * uy)  # r (and 1e-9 m) times |q - p|, for the side test below
    for w in range(seg.shape[0]):
        ax, ay, bx, by = seg[w, 0, 0], seg[w, 0, 1], seg[w, 1, 0], seg[w, 1, 1]
        # A wall farther than r from the line is skipped; the 1e-9 m beyond any rounding of the distance keep
        # the answers those of computing it. Farther along an axis: its bounding box is off the line's.
        gap_x = max(min(ax, bx) - max(px, qx), min(px, qx) - max(ax, bx))
        gap_y = max(min(ay, by) - max(py, qy), min(py, qy) - max(ay, by))
        if max(gap_x, gap_y) > r + 1e-9:
            continue
        # Both its ends on one side of the line's carrier, farther than r: so is all of it.
        da, db = ux * (ay - py) - uy * (ax - px), ux * (by - py) - uy * (bx - px)
        if (da > reach and db > reach) or (da < -reach and db < -reach):
            continue
        if _segment_distance(px, py, qx, qy, ax, ay, bx, by) < r:
            return False
    return True


@njit(cache=True)
def _visible(p, q, seg, r):
    """``(k, l)`` bool: the segment from ``p[i]`` to ``q[j]`` keeps >= ``r`` [m] from every wall
    segment ``seg`` ``(s, 2, 2)``."""
    k, l_ = p.shape[0], q.shape[0]
    out = np.ones((k, l_), dtype=np.bool_)
    for i in range(k):
        for j in range(l_):
            out[i, j] = _clear_line(p[i, 0], p[i, 1], q[j, 0], q[j, 1], seg, r)
    return out


@njit(cache=True)
def _visible_pairs(p, seg, r):
    """:func:`_visible` of the points ``p`` ``(k, 2)`` among themselves (symmetric: half the work)."""
    k = p.shape[0]
    out = np.ones((k, k), dtype=np.bool_)
    for i in range(k):
        for j in range(i + 1, k):
            out[i, j] = out[j, i] = _clear_line(p[i, 0], p[i, 1], p[j, 0], p[j, 1], seg, r)
    return out


@njit(cache=True)
def _clearance(x, y, seg):
    """:func:`vcs_env.walls.clearance` of one point ``(x, y)`` [m]."""
    c = np.inf
    for w in range(seg.shape[0]):
        d = _closest_approach(seg[w, 0, 0] - x, seg[w, 0, 1] - y, seg[w, 1, 0] - x, seg[w, 1, 1] - y)
        if d < c:
            c = d
    return c


@njit(cache=True)
def _next_waypoints(p, goal, nodes, cost, node_clearance, seg, r):
    """:meth:`Roadmap.next_waypoint` of ``k`` robots at once: positions ``p`` ``(k, 2)``, goals
    ``goal`` ``(k, 2)``, each goal's cost-to-go ``cost`` ``(k, N)``; ``node_clearance`` is the
    smallest clearance of the nodes [m] and ``r`` the lines' clearance [m]. Returns the waypoints
    ``(k, 2)`` and route lengths ``(k,)`` [m]."""
    k, N = p.shape[0], nodes.shape[0]
    target = goal.copy()
    length = np.full(k, np.inf)
    for i in range(k):
        px, py, gx, gy = p[i, 0], p[i, 1], goal[i, 0], goal[i, 1]
        cp = _clearance(px, py, seg)
        near = min(cp, _clearance(gx, gy, seg))
        if _clear_line(px, py, gx, gy, seg, min(r, near * (1.0 - 1e-9))):
            length[i] = math.sqrt((gx - px) * (gx - px) + (gy - py) * (gy - py))
            continue
        rr = min(r, min(cp, node_clearance) * (1.0 - 1e-9))
        best, j = np.inf, -1
        for q in range(N):  # the line check (the costly part) only for nodes that would improve
            dx, dy = nodes[q, 0] - px, nodes[q, 1] - py
            total = math.sqrt(dx * dx + dy * dy) + cost[i, q]
            if total < best and _clear_line(px, py, nodes[q, 0], nodes[q, 1], seg, rr):
                best, j = total, q
        if j >= 0:
            target[i, 0], target[i, 1], length[i] = nodes[j, 0], nodes[j, 1], best
    return target, length


@njit(cache=True)
def _dijkstra(edge, start):
    """Shortest distances ``(N,)`` [m] over the dense edge lengths ``edge`` ``(N, N)`` (inf: no
    edge) from the initial distances ``start`` ``(N,)``."""
    N = start.shape[0]
    dist = start.copy()
    done = np.zeros(N, dtype=np.bool_)
    for _ in range(N):
        u, best = -1, np.inf
        for v in range(N):
            if not done[v] and dist[v] < best:
                u, best = v, dist[v]
        if u < 0:
            break
        done[u] = True
        for v in range(N):
            alt = best + edge[u, v]
            if alt < dist[v]:
                dist[v] = alt
    return dist


class Roadmap:
    """Visibility graph of one set of walls for robots of one radius.

    Args:
        segments: walls ``(s, 2, 2)`` [m].
        radius: robot radius [m].
    """

    def __init__(self, segments: np.ndarray, radius: float):
        # A writable copy: the cached roadmaps' walls come from bytes (read-only), and numba compiles every kernel
        # that takes them once more for a read-only array (2 s at the first map of a process with a cold cache).
        self.segments = np.array(segments, dtype=np.float64).reshape(-1, 2, 2)
        self.radius = float(radius)
        self._r = self.radius + 0.5 * MARGIN  # lines of sight keep this from every wall
        rho = (self.radius + MARGIN) / math.cos(math.pi / _DIRECTIONS)
        ang = 2.0 * math.pi * np.arange(_DIRECTIONS) / _DIRECTIONS + math.pi / _DIRECTIONS
        ends = self.segments.reshape(-1, 2)
        dirs = np.stack((np.cos(ang), np.sin(ang)), -1)  # (8, 2)
        # Only directions beyond each end (away from its own segment): a route turns around an end.
        out = self.segments - self.segments[:, ::-1]  # (s, 2, 2): at end a, a - b; at end b, b - a
        outward = (out.reshape(-1, 2) @ dirs.T) > 0.0  # (2 s, 8)
        cand = (ends[:, None] + rho * dirs)[outward]
        # Beside each end, the two points of the same circle at 3 pi/8 from the outward direction,
        # r + MARGIN from the wall's line: without them the world's directions leave a wall at
        # 22.5 deg (mod 45) with no node beside it a route along it can use. For walls along the
        # axes they are nodes already (dropped as duplicates, so those roadmaps are unchanged).
        u = out.reshape(-1, 2) / np.linalg.norm(out.reshape(-1, 2), axis=-1, keepdims=True)  # (2 s, 2)
        side = []
        for a in (3 * math.pi / 8, -3 * math.pi / 8):  # u turned by a
            ca, sa = math.cos(a), math.sin(a)
            side.append(ends + rho * np.stack((ca * u[:, 0] - sa * u[:, 1], sa * u[:, 0] + ca * u[:, 1]), -1))
        side = np.concatenate(side)
        gap = np.sqrt(((side[:, None] - cand[None]) ** 2).sum(-1)).min(axis=1, initial=np.inf)
        cand = np.concatenate((cand, side[gap > 1e-9]))
        clear = clearance(cand, self.segments) >= self._r
        self.nodes = np.ascontiguousarray(cand[clear])  # (N, 2) [m]
        vis = _visible_pairs(self.nodes, self.segments, self._r)
        diff = self.nodes[:, None] - self.nodes[None]
        self._edge = np.where(vis, np.sqrt(np.einsum("...i,...i->...", diff, diff)), np.inf)
        self._costs: dict[tuple[float, float], np.ndarray] = {}
        self._node_clearance = float(clearance(self.nodes, self.segments).min(initial=np.inf))

    def sees(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """``(k, l)`` bool: points ``p`` ``(k, 2)`` see points ``q`` ``(l, 2)``: the lines keep
        ``radius + MARGIN / 2`` from every wall, or less if a point already sits closer (a robot
        pushed near a wall still sees the way out)."""
        p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 2)
        q = np.ascontiguousarray(q, dtype=np.float64).reshape(-1, 2)
        near = min(clearance(p, self.segments).min(initial=np.inf), clearance(q, self.segments).min(initial=np.inf))
        return _visible(p, q, self.segments, min(self._r, near * (1.0 - 1e-9)))

    def _sees_nodes(self, p: np.ndarray) -> np.ndarray:
        """:meth:`sees` of points ``p`` ``(k, 2)`` and the nodes, ``(k, N)`` bool, with the nodes' smallest clearance
        kept from construction (the same number :meth:`sees` finds) and the compiled clearance of each point."""
        p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 2)
        near = min([self._node_clearance] + [_clearance(x, y, self.segments) for x, y in p])
        return _visible(p, self.nodes, self.segments, min(self._r, near * (1.0 - 1e-9)))

    def cost_to_go(self, goal: np.ndarray) -> np.ndarray:
        """Route length from every node to ``goal`` ``(2,)`` [m], ``(N,)`` (inf: unreachable)."""
        key = (float(goal[0]), float(goal[1]))
        cost = self._costs.get(key)
        if cost is None:
            g = np.asarray(key)[None]
            start = np.where(self._sees_nodes(g)[0], np.linalg.norm(self.nodes - g, axis=-1), np.inf)
            cost = _dijkstra(self._edge, start)
            if len(self._costs) > 4096:
                self._costs.clear()
            self._costs[key] = cost
        return cost

    def next_waypoint(self, p: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """The point ``(2,)`` [m] to aim at from ``p`` ``(2,)`` toward ``goal`` ``(2,)`` and the
        route length [m] through it (inf and the goal itself when no route is seen)."""
        p, goal = np.asarray(p, dtype=np.float64), np.asarray(goal, dtype=np.float64)
        if self.sees(p[None], goal[None])[0, 0]:
            return goal, float(np.linalg.norm(goal - p))
        if len(self.nodes) == 0:
            return goal, math.inf
        total = np.where(
            self._sees_nodes(p[None])[0], np.linalg.norm(self.nodes - p, axis=-1) + self.cost_to_go(goal), np.inf
        )
        j = int(np.argmin(total))
        if not np.isfinite(total[j]):
            return goal, math.inf
        return self.nodes[j], float(total[j])

    def next_waypoints(self, p: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`next_waypoint` of many robots in one compiled call: ``p`` and ``goal`` ``(k, 2)``
        [m] give the waypoints ``(k, 2)`` [m] and route lengths ``(k,)`` [m] (inf: no route)."""
        p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 2)
        goal = np.ascontiguousarray(goal, dtype=np.float64).reshape(-1, 2)
        if len(p) < 16:
            cost = np.empty((len(p), len(self.nodes)))
            for i in range(len(p)):
                cost[i] = self.cost_to_go(goal[i])
        else:  # robots of many worlds share their goals: each goal's costs looked up once
            rows = goal.view(np.dtype((np.void, 2 * goal.itemsize))).reshape(-1)
            _, first, which = np.unique(rows, return_index=True, return_inverse=True)
            cost = np.stack([self.cost_to_go(goal[i]) for i in first])[which]
        return _next_waypoints(p, goal, self.nodes, cost, self._node_clearance, self.segments, self._r)

    def route_length(self, p: np.ndarray, goal: np.ndarray) -> float:
        """Length of the shortest roadmap route from ``p`` to ``goal`` [m] (inf: none)."""
        return self.next_waypoint(p, goal)[1]


@functools.lru_cache(maxsize=4096)
def _cached(key: bytes, count: int, radius: float) -> Roadmap:
    return Roadmap(np.frombuffer(key, dtype=np.float64).reshape(count, 2, 2), radius)


def roadmap(world: WorldState, b: int, radius: float) -> Roadmap:
    """The (cached) roadmap of world ``b``'s walls for robots of ``radius`` [m]."""
    seg = np.stack((world.seg_a[b], world.seg_b[b]), axis=1)[world.seg_present[b]]
    seg = np.ascontiguousarray(seg, dtype=np.float64)
    return _cached(seg.tobytes(), len(seg), float(radius))


def walled(world: WorldState) -> bool:
    """Has any world of the batch a wall segment? (Without walls routes are straight lines.)"""
    return world.n_segments > 0 and bool(world.seg_present.any())


_LAST: tuple = ((), None)
"""The last state :func:`waypoints` routed among walls (the bytes of what it reads) and its answer: the
observation, the reward and the planners ask for the same state within a step."""


def waypoints(world: WorldState) -> tuple[np.ndarray, np.ndarray]:
    """Every robot's next visible waypoint ``(B, n, 2)`` [m] and remaining route length
    ``(B, n)`` [m]: the goal and the straight distance without walls, for robots that are not
    active, or where no route is seen (then the planner aims straight at the goal)."""
    if not walled(world):
        return _straight(world)
    arrays = (world.pos, world.goal, world.active, world.radius, world.seg_a, world.seg_b, world.seg_present)
    key = tuple((a.dtype.str, a.shape, a.tobytes()) for a in arrays)
    last_key, answer = _LAST
    if key == last_key:
        return answer[0].copy(), answer[1].copy()
    answer = _routed(world)
    globals()["_LAST"] = (key, (answer[0].copy(), answer[1].copy()))  # one assignment: safe across threads
    return answer


def _straight(world: WorldState) -> tuple[np.ndarray, np.ndarray]:
    """The goal ``(B, n, 2)`` [m] and the straight distance to it ``(B, n)`` [m]."""
    diff = world.goal - world.pos
    return world.goal.copy(), np.sqrt(np.einsum("...i,...i->...", diff, diff))


def _routed(world: WorldState) -> tuple[np.ndarray, np.ndarray]:
    """:func:`waypoints` for a batch with walls."""
    target, length = _straight(world)
    # Worlds with the same walls (byte for byte: every world of a fixed map) share one roadmap per robot radius,
    # and their robots are routed in one call (each robot's route is its own: the same as one world at a time).
    B = world.batch_size
    if B == 1:
        groups = [(0, np.zeros(1, dtype=np.int64))]
    else:
        walls = np.concatenate(
            (world.seg_a.reshape(B, -1), world.seg_b.reshape(B, -1), world.seg_present.reshape(B, -1).astype(float)),
            axis=1,
        )
        rows = np.ascontiguousarray(walls).view(np.dtype((np.void, walls.shape[1] * walls.itemsize))).reshape(B)
        _, first, group = np.unique(rows, return_index=True, return_inverse=True)
        groups = zip(first, np.split(np.argsort(group, kind="stable"), np.cumsum(np.bincount(group))[:-1]))
    radii = np.unique(world.radius[world.active])  # usually one for the whole batch
    for b, idx in groups:
        if not world.seg_present[b].any():
            continue
        active, radius = world.active[idx], world.radius[idx]  # (k, n) of the k worlds with these walls
        for r in radii if len(radii) == 1 else np.unique(radius[active]):  # one roadmap per robot radius
            w, i = np.nonzero(active & (radius == r))
            if not len(w):
                continue
            w = idx[w]
            wp, total = roadmap(world, int(b), r).next_waypoints(world.pos[w, i], world.goal[w, i])
            found = np.isfinite(total)
            target[w[found], i[found]], length[w[found], i[found]] = wp[found], total[found]
    return target, length


def route_direction(world: WorldState, with_leg: bool = False) -> tuple[np.ndarray, ...]:
    """The vector toward each robot's next waypoint, scaled to the remaining route length
    ``(B, n, 2)`` [m], and that length ``(B, n)`` [m]: the goal offset and its length without
    walls (what :func:`baselines.common.preferred_velocity` aims along); with ``with_leg``, also the
    length of the next leg, the distance to that waypoint ``(B, n)`` [m]."""
    target, length = waypoints(world)
    e = target - world.pos
    d = np.sqrt(np.einsum("...i,...i->...", e, e))
    scaled = e * (length / np.maximum(d, 1e-12))[..., None]
    return (scaled, length, d) if with_leg else (scaled, length)
