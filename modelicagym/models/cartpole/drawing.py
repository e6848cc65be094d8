"""Draw a cart-pole scene into a numpy RGB image: no display, no extra dependency."""

from __future__ import annotations

import numpy as np

WIDTH, HEIGHT = 600, 400
_TRACK_Y = 300
_BACKGROUND, _TRACK, _CART, _POLE, _JOINT = (255, 255, 255), (0, 0, 0), (60, 60, 60), (202, 152, 101), (129, 132, 203)


def _fill_rectangle(image: np.ndarray, x0: float, y0: float, x1: float, y1: float, colour: tuple[int, int, int]) -> None:
    xs = slice(max(int(x0), 0), max(min(int(x1), image.shape[1]), 0))
    ys = slice(max(int(y0), 0), max(min(int(y1), image.shape[0]), 0))
    image[ys, xs] = colour


def _fill_disc(image: np.ndarray, cx: float, cy: float, radius: float, colour: tuple[int, int, int]) -> None:
    yy, xx = np.ogrid[: image.shape[0], : image.shape[1]]
    image[(xx - cx) ** 2 + (yy - cy) ** 2 <= radius**2] = colour


def _draw_segment(image: np.ndarray, start: tuple[float, float], end: tuple[float, float], width: float,
                  colour: tuple[int, int, int]) -> None:
    yy, xx = np.mgrid[: image.shape[0], : image.shape[1]]
    (ax, ay), (bx, by) = start, end
    dx, dy = bx - ax, by - ay
    t = np.clip(((xx - ax) * dx + (yy - ay) * dy) / max(dx * dx + dy * dy, 1e-12), 0.0, 1.0)
    image[(xx - ax - t * dx) ** 2 + (yy - ay - t * dy) ** 2 <= (width / 2) ** 2] = colour


def draw_cartpole(x: float, theta: float, pole_length: float, x_threshold: float) -> np.ndarray:
    """An RGB image (HEIGHT x WIDTH x 3, uint8) of a cart at ``x`` with its pole at angle ``theta``
    and the pole's point mass at its tip.

    ``theta`` is measured from the +x axis (upright = pi/2), as the model outputs it.
    """
    image = np.empty((HEIGHT, WIDTH, 3), dtype=np.uint8)
    image[:] = _BACKGROUND
    scale = WIDTH / (2.4 * x_threshold)
    cx, cy = WIDTH / 2 + x * scale, _TRACK_Y
    _fill_rectangle(image, 0, _TRACK_Y, WIDTH, _TRACK_Y + 2, _TRACK)
    _fill_rectangle(image, cx - 25, cy - 15, cx + 25, cy + 15, _CART)
    tip = (cx + np.cos(theta) * pole_length * scale, cy - np.sin(theta) * pole_length * scale)
    _draw_segment(image, (cx, cy), tip, 10, _POLE)
    _fill_disc(image, tip[0], tip[1], 9, _CART)
    _fill_disc(image, cx, cy, 5, _JOINT)
    return image
