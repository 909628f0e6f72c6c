"""The ``crowd`` scenario kind (CrowdNav's circle crossing): robots on a ring among obstacles that cross it. One
:class:`~vcs_env.layouts.ScenarioKind` listed in :data:`vcs_env.layouts.KINDS`, built from the shared blocks of
:mod:`vcs_env.layouts`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .layouts import ScenarioKind
from .placement import (
    CROWD_REDRAWS,
    MAX_TRIES,
    RING_NOISE,
    Ahead,
    Layout,
    check_ring,
    circle_points,
    crowd_ring,
    crowd_view,
    finish,
    obstacle_radii,
    on_ring,
    ring_crossers,
    walks_square,
)

if TYPE_CHECKING:
    from .scenario import Scenario


class Crowd(ScenarioKind):
    name = "crowd"
    obstacles_in_arena = False  # on the ring
    summary = (
        "robots on a circle (robot_0 from (0, -R) to (0, R)) among ``n_obstacles`` passive obstacles "
        "that cross the same circle and ignore the robots (CrowdNav style)."
    )
    reads = frozenset({"layout_radius"})

    def check_layout(self, s: Scenario) -> None:
        check_ring(s)
        r, r_obs = s.robot.radius, s.obstacle_radius[1]
        m = 0 if walks_square(s) else s.n_obstacles  # pedestrians crossing the square need no place on the ring
        if m and s.bounce and s.circle_radius + RING_NOISE + r_obs > s.arena_half_size:
            raise ValueError(
                f"crowd obstacles start on the ring of radius {s.circle_radius:g} m (+-{RING_NOISE:g} m), and their "
                f"discs (radius up to {r_obs:g} m) reach beyond the arena they bounce in (arena_half_size="
                f"{s.arena_half_size:g} m); increase arena_half_size or reduce layout_radius"
            )
        used, ring = crowd_ring(s, m)
        if used > ring:
            raise ValueError(
                f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles on a crowd circle of radius "
                f"{s.circle_radius:g} m: their starts and goals need {used:.1f} m of its {ring:.1f} m; "
                "increase layout_radius"
            )
        if m:  # the length of the ring is not the room between the robots: the first obstacle must fit
            start = circle_points(s.n_robots, s.circle_radius, -np.pi / 2)
            bodies = [(p, r) for p in np.concatenate((start, -start))]
            try:
                Crowd._search(np.random.default_rng(0), s, bodies, r_obs, 0)
            except ValueError:
                raise ValueError(
                    f"no crowd obstacle of radius {r_obs:g} m fits, start and antipodal goal, between {s.n_robots} "
                    f"robots of radius {r:g} m on a circle of radius {s.circle_radius:g} m; increase layout_radius or "
                    "reduce n_robots / robot radius / obstacle_radius / min_separation"
                ) from None

    def least_trip(self, s: Scenario) -> float:
        return max(0.0, 2.0 * s.circle_radius - s.r_goal)  # start and goal are antipodes of the ring

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        start = circle_points(s.n_robots, s.circle_radius, -np.pi / 2)
        goal = -start
        obs_pos, obs_target = np.zeros((2, s.n_obstacles, 2))  # square walkers without room on the ring: placed later
        for attempt in range(CROWD_REDRAWS if on_ring(s) else 0):
            try:
                obs_pos, obs_target = self._obstacles(rng, s, start, goal, obs_radius)
                break
            except ValueError:  # the obstacles placed first left no room for one: place them all again
                if attempt == CROWD_REDRAWS - 1 and not walks_square(s):
                    raise
        return finish(s, start, goal, obs_pos, obs_target, obs_radius)

    @staticmethod
    def _obstacles(
        rng: np.random.Generator, s: Scenario, start: np.ndarray, goal: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """CrowdNav circle crossing: obstacles start on the circle (with +-0.5 m noise) and head for
        the antipodal point; starts and goals keep clear of the robots' and of each other's."""
        m, R = len(radius), s.circle_radius
        if not np.array_equal(goal, -start):  # ring_crossers checks a start only: the goals of the bodies mirror it
            raise ValueError("crowd layout: the robots' goals must be their starts mirrored through the centre")
        pos = np.zeros((m, 2))
        centre = np.zeros((2 * s.n_robots + 2 * m, 2))
        centre[: 2 * s.n_robots] = np.concatenate((start, goal))
        rad = np.full(len(centre), float(s.robot.radius))
        k = tries = 0
        chunk, sep = 8 * m, s.min_separation
        while k < m:
            # Each try draws an angle on the circle and a +-0.5 m noise per axis (rng.uniform(0, 2 pi), then
            # rng.uniform(-0.5, 0.5, size=2)); drawn ahead in chunks, the loop compiled (ring_crossers).
            ahead = Ahead(rng, 3 * chunk)
            u = ahead.u.reshape(-1, 3)
            ang = (2.0 * np.pi) * u[:, 0]
            px = R * np.cos(ang) + (-RING_NOISE + 2.0 * RING_NOISE * u[:, 1])
            py = R * np.sin(ang) + (-RING_NOISE + 2.0 * RING_NOISE * u[:, 2])
            k, used, tries, status = ring_crossers(px, py, centre, rad, radius, k, tries, sep, MAX_TRIES, pos)
            ahead.settle(3 * used)
            if status == 2:  # the random draws found no room: search every place, in an order drawn from rng
                bodies = [(centre[b], rad[b]) for b in range(2 * s.n_robots + 2 * k)]
                p = Crowd._search(rng, s, bodies, radius[k], k)
                pos[k] = p
                j = 2 * s.n_robots + 2 * k
                centre[j], centre[j + 1], rad[j : j + 2] = p, -p, radius[k]
                k, tries = k + 1, 0
            chunk *= 2
        return pos, -pos

    @staticmethod
    def _search(rng: np.random.Generator, s: Scenario, bodies: list, r: float, k: int) -> np.ndarray:
        """The first of :meth:`_spots`, in an order drawn from ``rng``, whose start and antipodal goal keep
        clear of ``bodies`` (the random draws' test); ``ValueError`` if none does."""
        spots = Crowd._spots(s)
        spots = spots[rng.permutation(len(spots))]
        centre = np.array([c for c, _ in bodies])
        rad = np.array([rad for _, rad in bodies])
        fits = np.ones(len(spots), dtype=bool)
        for q in (spots, -spots):
            fits &= (np.linalg.norm(q[:, None] - centre[None], axis=-1) - rad - r >= s.min_separation).all(axis=1)
        if not fits.any():
            raise ValueError(
                f"could not place crowd obstacle {k} without overlap; "
                "increase layout_radius or reduce n_obstacles / min_separation"
            )
        return spots[np.argmax(fits)]

    @staticmethod
    def _spots(s: Scenario) -> np.ndarray:
        """Every start the random draw can give, on a grid ``(720 * 25, 2)`` [m]: 720 angles on the
        circle, each with a 5 x 5 grid of the +-0.5 m noise."""
        ang = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
        ring = s.circle_radius * np.stack((np.cos(ang), np.sin(ang)), axis=-1)
        off = np.stack(np.meshgrid(*2 * (np.linspace(-RING_NOISE, RING_NOISE, 5),)), axis=-1).reshape(-1, 2)
        return (ring[:, None] + off[None]).reshape(-1, 2)

    def view_extent(self, s: Scenario) -> float:
        return crowd_view(s)
