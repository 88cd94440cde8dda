"""Vectorised numpy drawing into (H, W, 3) uint8 images: lines, convex polygons, discs and bitmap text.

The episode renderer (`auv_mj.render`) reads back only MuJoCo's geoms from OpenGL and draws its
decorations with these: a CPU rasteriser (Mesa llvmpipe) pays for every pixel of a full-screen quad,
numpy only for the pixels a line or a marker touches. Coordinates are pixels, (column, row) from the
top-left corner; pixel (r, c) covers [c, c + 1) x [r, r + 1).
"""

from __future__ import annotations

import mujoco
import numpy as np

OVERLAY_PAD = 5
"""Padding [px] of MuJoCo's text overlay boxes (`mjr_overlay`), reproduced by `BitmapFont.overlay`."""


def _clip_segments(starts: np.ndarray, ends: np.ndarray, width: int, height: int,
                   margin: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts of segments inside the image (plus `margin`), Liang-Barsky, all segments at once, and
    which segments have such a part."""
    d = ends - starts
    t0, t1 = np.zeros(len(d)), np.ones(len(d))
    lo, hi = np.array([-margin, -margin]), np.array([width + margin, height + margin])
    for axis in (0, 1):
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (lo[axis] - starts[:, axis]) / d[:, axis]
            tb = (hi[axis] - starts[:, axis]) / d[:, axis]
        parallel = d[:, axis] == 0
        inside = (starts[:, axis] >= lo[axis]) & (starts[:, axis] <= hi[axis])
        t0 = np.where(parallel, np.where(inside, t0, 2.0), np.maximum(t0, np.minimum(ta, tb)))
        t1 = np.where(parallel, np.where(inside, t1, -1.0), np.minimum(t1, np.maximum(ta, tb)))
    keep = t0 <= t1
    return starts[keep] + t0[keep, None] * d[keep], starts[keep] + t1[keep, None] * d[keep], keep


def line_pixels(starts: np.ndarray, ends: np.ndarray, width: int, shape: tuple[int, int]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, columns) of the pixels of `width`-pixel lines from `starts` to `ends` (N, 2), and each pixel's
    segment.

    Like OpenGL's aliased wide lines: one sample per pixel along the major axis, `width` pixels across it.
    """
    height, image_width = shape
    a, b, keep = _clip_segments(np.asarray(starts, float), np.asarray(ends, float), image_width, height)
    if len(a) == 0:
        empty = np.zeros(0, np.intp)
        return empty, empty, empty
    d = b - a
    steps = np.maximum(np.ceil(np.abs(d).max(axis=1)).astype(np.intp), 1)
    n = steps + 1
    segment = np.repeat(np.arange(len(a)), n)
    k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    t = k / steps[segment]
    cols = np.floor(a[segment, 0] + t * d[segment, 0]).astype(np.intp)
    rows = np.floor(a[segment, 1] + t * d[segment, 1]).astype(np.intp)
    if width > 1:
        offsets = np.arange(width) - (width - 1) // 2
        x_major = (np.abs(d[:, 0]) >= np.abs(d[:, 1]))[segment, None]
        rows = (rows[:, None] + np.where(x_major, offsets, 0)).ravel()
        cols = (cols[:, None] + np.where(x_major, 0, offsets)).ravel()
        segment = np.repeat(segment, width)
    inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < image_width)
    return rows[inside], cols[inside], np.flatnonzero(keep)[segment[inside]]


def paint(image: np.ndarray, rows: np.ndarray, cols: np.ndarray, colour: np.ndarray, alpha: float = 1.0) -> None:
    """Sets the pixels (`rows`, `cols`) to `colour` ((3,) or one per pixel, 0-255), blended with what is
    there when `alpha` < 1."""
    if alpha >= 1.0:
        image[rows, cols] = colour
    else:
        image[rows, cols] = (image[rows, cols] * (1.0 - alpha) + np.asarray(colour, float) * alpha
                             + 0.5).astype(np.uint8)


def lines(image: np.ndarray, starts: np.ndarray, ends: np.ndarray, colour, width: int,
          alpha: float = 1.0) -> None:
    """Draws segments (N, 2) -> (N, 2) in one colour ((3,) 0-255) or one colour per segment ((N, 3))."""
    if len(starts) == 0:
        return
    rows, cols, segment = line_pixels(starts, ends, width, image.shape[:2])
    colour = np.asarray(colour)
    paint(image, rows, cols, colour[segment] if colour.ndim == 2 else colour, alpha)


def _box(image: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int, int, int] | None:
    """Integer (row0, row1, col0, col1) of the pixels whose centres may lie in [lo, hi], clipped."""
    h, w = image.shape[:2]
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return None
    c0, r0 = np.maximum(np.floor(lo - 0.5).astype(int), 0)
    c1, r1 = np.minimum(np.ceil(hi + 0.5).astype(int), (w, h))
    return None if c0 >= c1 or r0 >= r1 else (r0, r1, c0, c1)


def _blend(region: np.ndarray, mask: np.ndarray, colour, alpha: float) -> None:
    if alpha >= 1.0:
        region[mask] = colour
    else:
        region[mask] = (region[mask] * (1.0 - alpha) + np.asarray(colour, float) * alpha + 0.5).astype(np.uint8)


def fill_polygon(image: np.ndarray, vertices: np.ndarray, colour, alpha: float = 1.0) -> None:
    """Fills a convex polygon (K, 2) of either winding: the pixels whose centres lie inside it."""
    vertices = np.asarray(vertices, float)
    box = _box(image, vertices.min(axis=0), vertices.max(axis=0))
    if box is None:
        return
    r0, r1, c0, c1 = box
    x = np.arange(c0, c1) + 0.5
    y = (np.arange(r0, r1) + 0.5)[:, None]
    edges = np.roll(vertices, -1, axis=0) - vertices
    area = np.sum(vertices[:, 0] * np.roll(vertices[:, 1], -1) - np.roll(vertices[:, 0], -1) * vertices[:, 1])
    sign = 1.0 if area >= 0 else -1.0
    mask = np.ones((r1 - r0, c1 - c0), bool)
    for (vx, vy), (ex, ey) in zip(vertices, edges, strict=True):
        mask &= sign * (ex * (y - vy) - ey * (x - vx)) >= 0
    _blend(image[r0:r1, c0:c1], mask, colour, alpha)


def fill_disc(image: np.ndarray, centre, radius: float, colour, alpha: float = 1.0) -> None:
    """Fills the pixels whose centres lie within `radius` of `centre`."""
    centre = np.asarray(centre, float)
    box = _box(image, centre - radius, centre + radius)
    if box is None:
        return
    r0, r1, c0, c1 = box
    dx = np.arange(c0, c1) + 0.5 - centre[0]
    dy = (np.arange(r0, r1) + 0.5)[:, None] - centre[1]
    _blend(image[r0:r1, c0:c1], dx * dx + dy * dy <= radius * radius, colour, alpha)


def fill_squares(image: np.ndarray, centres: np.ndarray, half: float, colours: np.ndarray) -> None:
    """Axis-aligned squares of half-size `half` [px] around `centres` (N, 2), one colour each."""
    for centre, colour in zip(np.asarray(centres, float), colours, strict=True):
        box = _box(image, centre - half, centre + half)
        if box is not None:
            r0, r1, c0, c1 = box
            image[r0:r1, c0:c1] = colour


def darken(region: np.ndarray, keep: float) -> None:
    """Blends `region` in place with black, keeping the fraction `keep` (a translucent black box)."""
    if keep == 0.5:
        np.right_shift(region, 1, out=region)
    else:
        region[...] = (region * keep).astype(np.uint8)


class BitmapFont:
    """One of a MuJoCo context's bitmap fonts as numpy glyph masks, to draw text without OpenGL.

    MuJoCo draws text with `glBitmap`: each character a `charWidth` x `charHeight` cell of on/off pixels,
    so text is the concatenation of these cells. The cells are read back once from OpenGL (the context
    must be current, drawing to its offscreen buffer of at least `width` x `height`).
    """

    def __init__(self, context: mujoco.MjrContext, font: int, width: int, height: int):
        big = font == mujoco.mjtFont.mjFONT_BIG
        self.height = context.charHeightBig if big else context.charHeight
        self.widths = np.array(context.charWidthBig if big else context.charWidth, dtype=int)
        self.cells: dict[str, np.ndarray] = {}
        full = mujoco.MjrRect(0, 0, width, height)
        pixels = np.empty((height, width, 3), np.uint8)
        chars = [chr(c) for c in range(32, 127) if self.widths[c] > 0]
        while chars:
            chunk = []
            while chars and sum(self.widths[ord(c)] for c in chunk) + self.widths[ord(chars[0])] < width - 4:
                chunk.append(chars.pop(0))
            if not chunk or self.height + 4 > height:
                break
            mujoco.mjr_rectangle(full, 0.0, 0.0, 1.0, 1.0)
            # Raster position (2.5, 2.5) px: the cells' lower-left corner is pixel (2, 2) of the buffer.
            mujoco.mjr_text(font, "".join(chunk), context, 2.5 / width, 2.5 / height, 1.0, 1.0, 1.0)
            mujoco.mjr_readPixels(pixels, None, full, context)
            on = pixels[2:2 + self.height, :, 0] > 127  # bottom-up rows, as read back
            x = 2
            for c in chunk:
                self.cells[c] = on[::-1, x:x + self.widths[ord(c)]]
                x += self.widths[ord(c)]
        self._lines: dict[str, np.ndarray] = {}

    def width(self, text: str) -> int:
        """Width [px] of one line of text."""
        return int(sum(self.widths[ord(c)] for c in text if ord(c) < len(self.widths)))

    def mask(self, text: str) -> np.ndarray:
        """(charHeight, width) bool mask of one line of text (cached: most lines repeat frame to frame)."""
        mask = self._lines.get(text)
        if mask is None:
            cells = [self.cells[c] for c in text if c in self.cells]
            mask = np.concatenate(cells, axis=1) if cells else np.zeros((self.height, 0), bool)
            if len(self._lines) > 4096:
                self._lines.clear()
            self._lines[text] = mask
        return mask

    def text(self, image: np.ndarray, text: str, left: int, bottom: int, colour) -> None:
        """Draws one line with its cells' lower-left corner at (`left`, `bottom`) in OpenGL window pixels
        (rows counted upwards from the bottom of `image`)."""
        mask = self.mask(text)
        h, w = image.shape[:2]
        top = h - bottom - self.height
        r0, c0 = max(top, 0), max(left, 0)
        r1, c1 = min(top + mask.shape[0], h), min(left + mask.shape[1], w)
        if r0 < r1 and c0 < c1:
            image[r0:r1, c0:c1][mask[r0 - top:r1 - top, c0 - left:c1 - left]] = colour

    def overlay(self, image: np.ndarray, gridpos: int, viewport: tuple[int, int, int, int], text: str,
                text2: str = "") -> None:
        """`mjr_overlay` in numpy: the text (and a second column) on a half-black box at a corner of
        `viewport` (left, bottom, width, height in OpenGL window pixels)."""
        if text2:
            left_side = gridpos in (mujoco.mjtGridPos.mjGRID_TOPLEFT, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT)
            first, second = ((text, (178, 178, 178)), (text2, (255, 255, 255)))[::1 if left_side else -1]
            skip = self._column(image, gridpos, viewport, 0, *first)
            self._column(image, gridpos, viewport, skip, *second)
        else:
            self._column(image, gridpos, viewport, 0, text, (255, 255, 255))

    def _column(self, image: np.ndarray, gridpos: int, viewport, skip: int, text: str, colour) -> int:
        pad, rows = OVERLAY_PAD, text.split("\n")
        width = pad + max(self.width(r) for r in rows) + 8
        height = pad + len(rows) * self.height + (len(rows) - 1) * pad
        vl, vb, vw, vh = viewport
        top = gridpos in (mujoco.mjtGridPos.mjGRID_TOPLEFT, mujoco.mjtGridPos.mjGRID_TOPRIGHT)
        left_side = gridpos in (mujoco.mjtGridPos.mjGRID_TOPLEFT, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT)
        left = vl + skip + pad if left_side else vl + vw - skip - 1 - pad - width
        bottom = vb + vh - 1 - pad - height if top else vb + pad
        h, w = image.shape[:2]
        r0, r1 = max(h - bottom - height, 0), min(h - bottom, h)
        c0, c1 = max(left, 0), min(left + width, w)
        if r0 < r1 and c0 < c1:
            darken(image[r0:r1, c0:c1], 0.5)
        for i, row in enumerate(rows):
            self.text(image, row, left + 3, bottom + height - self.height - i * (pad + self.height), colour)
        return width - 2
