"""Rendering: pygame frames (``human`` window or ``rgb_array``), text (``ansi``), GIF/MP4 writers
and a matplotlib trajectory plot. pygame, Pillow, imageio and matplotlib are imported lazily
(the ``render`` extra); headless machines need ``SDL_VIDEODRIVER=dummy``. Gymnasium's own
``RecordVideo`` wrapper writes with moviepy, which the extra does not install (``pip install moviepy``);
``vcs-env rollout --gif``/``--video`` and :func:`write_video` use imageio.
"""

from __future__ import annotations

import colorsys
import itertools
import os
from collections.abc import Iterable

import numpy as np

from .checks import install_hint
from .state import WorldState

OBSTACLE_COLOR = (120, 120, 120)
WALL_COLOR = (40, 40, 40)
BACKGROUND = (250, 250, 250)


def robot_colors(n: int) -> list[tuple[int, int, int]]:
    """``n`` well separated colours (RGB 0-255)."""
    return [tuple(int(255 * c) for c in colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.75, 0.85)) for i in range(n)]


def _missing(extra_pkg: str, err: ImportError) -> ImportError:
    return ImportError(f"{extra_pkg} is needed for this; install it with: {install_hint('render')} ({err})")


class Renderer:
    """Draws world 0 of a :class:`WorldState`.

    Args:
        extent: half size of the drawn square [m] (centred on the origin).
        size: image side [px].
        mode: ``"human"`` opens a window; ``"rgb_array"`` draws off-screen.
        fps: frame rate of the human window [1/s] (the adapters pass 1 / dt: real time).
    """

    windows = 0
    """Human renderers open in this process: pygame has one display, closed when the last of them closes."""

    def __init__(self, extent: float, size: int = 600, mode: str = "rgb_array", fps: float = 10.0):
        self.extent, self.size, self.mode, self.fps = float(extent), int(size), mode, fps
        self._pg = None
        self._clock = None
        self.trails: list[np.ndarray] = []

    def _pygame(self):
        if self._pg is None:
            os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
            try:
                import pygame
                import pygame.gfxdraw  # noqa: F401
            except ImportError as e:
                raise _missing("pygame", e) from None
            self._pg = pygame  # no pygame.init(): off-screen drawing needs none, and its audio and video probes print
            # errors on a machine without them (the window's display is opened in _window)
            if self.mode == "human":
                Renderer.windows += 1
                self._clock = pygame.time.Clock()
        return self._pg

    def _window(self, pg):
        """The process's pygame window, opened again if it was closed (by code of one's own) or has another size."""
        screen = pg.display.get_surface() if pg.display.get_init() else None
        if screen is None or screen.get_size() != (self.size, self.size):
            pg.display.init()
            screen = pg.display.set_mode((self.size, self.size))
            pg.display.set_caption("vcs-env")
        return screen

    def _px(self, p: np.ndarray) -> np.ndarray:
        """Pixel coordinates of points ``p`` ``(..., 2)`` [m]; points far outside the view are clipped to
        8 view sizes around it (off the picture either way), as pygame draws in 16-bit integers."""
        scale = self.size / (2.0 * self.extent)
        x = (p[..., 0] + self.extent) * scale
        y = (self.extent - p[..., 1]) * scale
        return np.clip(np.stack((x, y), axis=-1), -8.0 * self.size, 9.0 * self.size)

    def reset(self) -> None:
        self.trails = []

    def draw(self, world: WorldState):
        """Draw world 0; returns an ``(H, W, 3)`` uint8 array (rgb_array) or None (human)."""
        pg = self._pygame()
        scale = self.size / (2.0 * self.extent)
        surf = pg.Surface((self.size, self.size))
        surf.fill(BACKGROUND)
        n = world.n_robots
        colors = robot_colors(n)
        self.trails.append(world.pos[0].copy())
        if len(self.trails) > 1:
            trail = self._px(np.asarray(self.trails))
            for i in range(n):
                light = tuple(int(c + (255 - c) * 0.6) for c in colors[i])
                pg.draw.lines(surf, light, False, trail[:, i].tolist(), 2)
        for k in np.flatnonzero(world.seg_present[0]):  # walls: the collision segments themselves
            a, b = self._px(world.seg_a[0, k]), self._px(world.seg_b[0, k])
            pg.draw.line(surf, WALL_COLOR, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 3)
        for k in range(world.n_obstacles):
            c = self._px(world.obs_pos[0, k])
            r = max(1, int(world.obs_radius[0, k] * scale))
            pg.gfxdraw.filled_circle(surf, int(c[0]), int(c[1]), r, OBSTACLE_COLOR)
            pg.gfxdraw.aacircle(surf, int(c[0]), int(c[1]), r, (60, 60, 60))
        for i in range(n):
            g = self._px(world.goal[0, i])
            rg = max(3, int(world.r_goal * scale))
            pg.draw.circle(surf, colors[i], (int(g[0]), int(g[1])), rg, 2)
        for i in range(n):
            if not world.present[0, i]:
                continue
            c = self._px(world.pos[0, i])
            r = max(2, int(world.radius[0, i] * scale))
            col = colors[i] if world.active[0, i] else tuple(int(0.5 * v + 100) for v in colors[i])
            pg.gfxdraw.filled_circle(surf, int(c[0]), int(c[1]), r, col)
            edge = (220, 0, 0) if world.collided[0, i] else (30, 30, 30)
            pg.gfxdraw.aacircle(surf, int(c[0]), int(c[1]), r, edge)
            tip = self._px(
                world.pos[0, i]
                + world.radius[0, i] * np.array([np.cos(world.heading[0, i]), np.sin(world.heading[0, i])])
            )
            pg.draw.line(surf, (20, 20, 20), (int(c[0]), int(c[1])), (int(tip[0]), int(tip[1])), 2)
        if self.mode == "human":
            self._window(pg).blit(surf, (0, 0))
            pg.event.pump()
            pg.display.flip()
            self._clock.tick(self.fps)
            return None
        # Row-major RGB bytes in one copy (surfarray's column-major array and its transpose took 4x longer).
        rgb = bytearray(pg.image.tobytes(surf, "RGB"))
        return np.frombuffer(rgb, dtype=np.uint8).reshape(surf.get_height(), surf.get_width(), 3)

    def close(self) -> None:
        if self._pg is not None and self.mode == "human":
            Renderer.windows -= 1
            if Renderer.windows == 0:  # another env's window stays open
                self._pg.display.quit()
        self._pg = None


class RenderMixin:
    """``render()`` and ``close()`` of the API adapters, which provide ``render_mode``,
    ``scenario``, ``engine``, ``metadata`` and ``_renderer``; and their state for ``pickle`` and ``copy.deepcopy``."""

    def __getstate__(self):
        """The env's whole state, mid-episode included (a copy continues as the env would; gymnasium's EzPickle rebuilt
        an env never reset from the constructor's arguments); the renderer stays behind (a copy that renders opens
        its own, its trails starting afresh)."""
        return {**self.__dict__, "_renderer": None}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    def render(self):
        if not getattr(self, "_started", True):  # the world holds no episode yet (the PettingZoo env says)
            raise RuntimeError("render() called before the first reset(); call reset() first")
        if self.render_mode is None:
            import gymnasium

            gymnasium.logger.warn("render() called without a render_mode; pass render_mode= to the env")
            return None
        if self.render_mode == "ansi":
            return ansi(self.engine.world)
        if self._renderer is None:
            self._renderer = Renderer(self.scenario.view_extent, mode=self.render_mode, fps=self.metadata["render_fps"])
        return self._renderer.draw(self.engine.world)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def ansi(world: WorldState) -> str:
    """A one-line-per-robot text view of world 0."""
    walls = int(world.seg_present[0].sum())
    lines = [f"t={world.time[0]:.1f}s" + (f" walls={walls}" if walls else "")]
    for i in range(world.n_robots):
        status = "arrived" if world.reached[0, i] else ("crashed" if not world.active[0, i] else "driving")
        x, y = world.pos[0, i]
        gx, gy = world.goal[0, i]
        lines.append(
            f"robot_{i}: pos=({x:6.2f},{y:6.2f}) heading={world.heading[0, i]:+.2f} speed={world.speed[0, i]:.2f} "
            f"goal=({gx:6.2f},{gy:6.2f}) {status}"
        )
    return "\n".join(lines)


def write_video(frames: Iterable[np.ndarray], path: str, fps: int = 10) -> str:
    """Write ``(H, W, 3)`` uint8 frames to a ``.gif`` (Pillow) or ``.mp4`` (imageio-ffmpeg). The frames are
    converted one at a time as they are written (a generator of them is never held whole; Pillow's GIF writer keeps
    each frame in its palette form, a third of its size, until the file is written)."""
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise ValueError("no frames to write")
    frames = itertools.chain([first], frames)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".gif":
        try:
            from PIL import Image
        except ImportError as e:
            raise _missing("Pillow", e) from None
        images = (Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames)
        head = next(images)
        head.save(path, save_all=True, append_images=images, duration=int(1000 / fps), loop=0, optimize=True)
    elif ext == ".mp4":
        try:
            import imageio.v2 as imageio
        except ImportError as e:
            raise _missing("imageio", e) from None
        with imageio.get_writer(path, fps=fps, macro_block_size=1) as writer:
            for f in frames:
                writer.append_data(np.asarray(f, dtype=np.uint8))
    else:
        raise ValueError(f"video path must end in .gif or .mp4, got {path!r}")
    return path


def plot_trajectories(
    pos, goal, radius, obs_pos=None, obs_radius=None, ax=None, title: str | None = None, segments=None
):
    """Matplotlib plot of one episode.

    Args:
        pos: robot positions over time ``(T, n, 2)`` [m].
        goal: ``(n, 2)`` [m].
        radius: ``(n,)`` [m].
        obs_pos: obstacle positions over time ``(T, m, 2)`` [m] (optional).
        obs_radius: ``(m,)`` [m].
        ax: axes to draw on (a new figure otherwise).
        segments: wall segments ``(s, 2, 2)`` [m] (optional; NaN rows are skipped, as in
            :attr:`vcs_env.rollout.Episode.segments`).

    Returns:
        The axes.
    """
    try:
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle
    except ImportError as e:
        raise _missing("matplotlib", e) from None
    pos = np.asarray(pos)
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    colors = [tuple(c / 255 for c in col) for col in robot_colors(pos.shape[1])]
    if segments is not None:
        for a, b in np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2):
            if np.all(np.isfinite(a)) and np.all(np.isfinite(b)):
                ax.plot((a[0], b[0]), (a[1], b[1]), color=tuple(c / 255 for c in WALL_COLOR), lw=2.5)
    if obs_pos is not None and np.asarray(obs_pos).size:
        obs_pos = np.asarray(obs_pos)
        for k in range(obs_pos.shape[1]):
            ax.plot(obs_pos[:, k, 0], obs_pos[:, k, 1], color="0.6", lw=1, ls="--")
            ax.add_patch(Circle(obs_pos[-1, k], obs_radius[k], color="0.5", alpha=0.6))
    for i in range(pos.shape[1]):
        ax.plot(pos[:, i, 0], pos[:, i, 1], color=colors[i], lw=1.5)
        ax.add_patch(Circle(pos[0, i], radius[i], fill=False, color=colors[i], ls=":"))
        ax.add_patch(Circle(pos[-1, i], radius[i], color=colors[i], alpha=0.7))
        ax.plot(*goal[i], marker="x", color=colors[i])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    return ax
