"""Vectorised numpy drawing into (H, W, 3) uint8 images: lines, squares, convex polygons, discs, bitmap text.

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


Clip = tuple[int, int, int, int]
"""(row0, row1, col0, col1): the part of an image a view covers; drawing stays inside it."""


def _clip_segments(starts: np.ndarray, ends: np.ndarray, clip: Clip, margin: float = 2.0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts of segments inside `clip` (plus `margin`), Liang-Barsky, all segments at once, and which
    segments have such a part."""
    d = ends - starts
    t0, t1 = np.zeros(len(d)), np.ones(len(d))
    lo = np.array([clip[2] - margin, clip[0] - margin])
    hi = np.array([clip[3] + margin, clip[1] + margin])
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


def line_pixels(starts: np.ndarray, ends: np.ndarray, widths: np.ndarray, image_width: int, clip: Clip
                ) -> tuple[np.ndarray, np.ndarray]:
    """Flat pixel indices (into an image `image_width` wide) of lines from `starts` to `ends` (N, 2),
    `widths` (N,) pixels wide, inside `clip`, and each pixel's segment.

    Like OpenGL's aliased wide lines: one sample per pixel along the major axis, `width` pixels across it.
    """
    lo, hi = np.minimum(starts.min(axis=0), ends.min(axis=0)), np.maximum(starts.max(axis=0), ends.max(axis=0))
    if lo[0] >= clip[2] and lo[1] >= clip[0] and hi[0] <= clip[3] and hi[1] <= clip[1]:
        a, b, keep = starts, ends, np.ones(len(starts), bool)  # all inside: nothing to clip
    else:
        a, b, keep = _clip_segments(starts, ends, clip)
    if len(a) == 0:
        empty = np.zeros(0, np.intp)
        return empty, empty
    d = b - a
    steps = np.maximum(np.ceil(np.abs(d).max(axis=1)), 1.0)
    n = steps.astype(np.intp) + 1
    segment = np.repeat(np.arange(len(a)), n)
    k = np.arange(len(segment), dtype=float)
    k -= np.repeat(np.cumsum(n) - n, n)
    inc = d / steps[:, None]
    cols = np.floor(np.repeat(a[:, 0], n) + k * np.repeat(inc[:, 0], n)).astype(np.intp)
    rows = np.floor(np.repeat(a[:, 1], n) + k * np.repeat(inc[:, 1], n)).astype(np.intp)
    widths = np.asarray(widths, np.intp)[keep]
    wide = int(widths.max())
    if wide > 1:
        # Per segment, the offsets across it: along rows for mostly horizontal lines, else along columns.
        offsets = np.arange(wide) - ((widths - 1) // 2)[:, None]
        x_major = np.abs(d[:, 0]) >= np.abs(d[:, 1])
        row_offsets = np.repeat(np.where(x_major[:, None], offsets, 0), n, axis=0)
        col_offsets = np.repeat(np.where(x_major[:, None], 0, offsets), n, axis=0)
        valid = np.repeat(np.arange(wide) < widths[:, None], n, axis=0).ravel()
        rows = (rows[:, None] + row_offsets).ravel()[valid]
        cols = (cols[:, None] + col_offsets).ravel()[valid]
        segment = np.repeat(segment, wide)[valid]
    inside = (rows >= clip[0]) & (rows < clip[1]) & (cols >= clip[2]) & (cols < clip[3])
    return rows[inside] * image_width + cols[inside], np.flatnonzero(keep)[segment[inside]]


def lines(image: np.ndarray, starts: np.ndarray, ends: np.ndarray, colours: np.ndarray, widths: np.ndarray,
          alphas: np.ndarray, clip: Clip, hidden: np.ndarray | None = None) -> None:
    """Draws segments (N, 2) -> (N, 2), each with its colour (N, 3) [0-255], width [px] and opacity, in
    order (a later segment covers an earlier one), inside `clip` of the contiguous `image`, except on the
    pixels `hidden` (an image-sized mask, or None)."""
    if len(starts) == 0:
        return
    flat, segment = line_pixels(starts, ends, widths, image.shape[1], clip)
    if hidden is not None:
        shown = ~hidden.reshape(-1)[flat]
        flat, segment = flat[shown], segment[shown]
    # Channel by channel through the flat bytes: 1-D gathers and scatters are what numpy does fastest.
    data, base = image.reshape(-1), flat * 3
    colours, alphas = np.asarray(colours, float), np.asarray(alphas, float)
    translucent = alphas < 1.0
    blend = translucent[segment] if np.any(translucent) else None
    if blend is not None:
        alpha = alphas[segment[blend]]
    for channel in range(3):
        values = colours[:, channel].astype(np.uint8)[segment]
        if blend is not None:
            under = data[base[blend] + channel]
            values[blend] = under * (1.0 - alpha) + colours[segment[blend], channel] * alpha + 0.5
        data[base + channel] = values


def _box(lo: np.ndarray, hi: np.ndarray, clip: Clip) -> Clip | None:
    """Integer (row0, row1, col0, col1) of the pixels whose centres may lie in [lo, hi] (x, y), in `clip`."""
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return None
    c0, r0 = int(max(np.floor(lo[0] - 0.5), clip[2])), int(max(np.floor(lo[1] - 0.5), clip[0]))
    c1, r1 = int(min(np.ceil(hi[0] + 0.5), clip[3])), int(min(np.ceil(hi[1] + 0.5), clip[1]))
    return None if c0 >= c1 or r0 >= r1 else (r0, r1, c0, c1)


def _blend(image: np.ndarray, box: Clip, mask: np.ndarray, colour, alpha: float, hidden: np.ndarray | None
           ) -> None:
    r0, r1, c0, c1 = box
    region = image[r0:r1, c0:c1]
    if hidden is not None:
        mask = mask & ~hidden[r0:r1, c0:c1]
    if alpha >= 1.0:
        region[mask] = colour
    else:
        region[mask] = (region[mask] * (1.0 - alpha) + np.asarray(colour, float) * alpha + 0.5).astype(np.uint8)


def fill_polygon(image: np.ndarray, vertices: np.ndarray, colour, clip: Clip, hidden: np.ndarray | None = None
                 ) -> None:
    """Fills a convex polygon (K, 2) of either winding: the pixels whose centres lie inside it."""
    mask, row, col = polygon_mask(vertices)
    stamp(image, mask, row, col, colour, clip, hidden)


def fill_disc(image: np.ndarray, centre, radius: float, colour, clip: Clip, hidden: np.ndarray | None = None,
              alpha: float = 1.0) -> None:
    """Fills the pixels whose centres lie within `radius` of `centre`."""
    centre = np.asarray(centre, float)
    box = _box(centre - radius, centre + radius, clip)
    if box is None:
        return
    r0, r1, c0, c1 = box
    dx = np.arange(c0, c1) + 0.5 - centre[0]
    dy = (np.arange(r0, r1) + 0.5)[:, None] - centre[1]
    _blend(image, box, dx * dx + dy * dy <= radius * radius, colour, alpha, hidden)


def fill_squares(image: np.ndarray, centres: np.ndarray, size: int, colours: np.ndarray, clip: Clip,
                 hidden: np.ndarray | None = None) -> None:
    """Axis-aligned squares of `size` pixels around `centres` (N, 2), one colour each (the pixels whose
    centres lie within size / 2 of the centre), all in one assignment."""
    if len(centres) == 0:
        return
    first = np.ceil(np.asarray(centres, float) - size / 2 - 0.5).astype(np.intp)  # (col, row) of the corner
    span = np.arange(size)
    cols = (first[:, 0, None, None] + span[None, None, :]).repeat(size, axis=1).reshape(-1)
    rows = (first[:, 1, None, None] + span[None, :, None]).repeat(size, axis=2).reshape(-1)
    square = np.repeat(np.arange(len(first)), size * size)
    inside = (rows >= clip[0]) & (rows < clip[1]) & (cols >= clip[2]) & (cols < clip[3])
    flat, square = rows[inside] * image.shape[1] + cols[inside], square[inside]
    if hidden is not None:
        shown = ~hidden.reshape(-1)[flat]
        flat, square = flat[shown], square[shown]
    image.reshape(-1, 3)[flat] = colours[square]


def polygon_mask(vertices: np.ndarray) -> tuple[np.ndarray, int, int]:
    """A convex polygon (K, 2) as a bool mask of the pixels whose centres lie inside it, and the (row,
    column) of the mask's corner."""
    vertices = np.asarray(vertices, float)
    c0, r0 = np.floor(vertices.min(axis=0)).astype(int)
    c1, r1 = np.ceil(vertices.max(axis=0)).astype(int) + 1
    x = np.arange(c0, c1) + 0.5
    y = (np.arange(r0, r1) + 0.5)[:, None]
    nxt = np.roll(vertices, -1, axis=0)
    sign = 1.0 if np.sum(vertices[:, 0] * nxt[:, 1] - nxt[:, 0] * vertices[:, 1]) >= 0 else -1.0
    mask = np.ones((r1 - r0, c1 - c0), bool)
    for (vx, vy), (ex, ey) in zip(vertices, nxt - vertices, strict=True):
        mask &= sign * (ex * (y - vy) - ey * (x - vx)) >= 0
    return mask, int(r0), int(c0)


def stamp(image: np.ndarray, mask: np.ndarray, row: int, col: int, colour, clip: Clip,
          hidden: np.ndarray | None = None) -> None:
    """Sets the pixels of `mask` placed with its corner at (`row`, `col`) to `colour`, inside `clip`."""
    r0, c0 = max(row, clip[0]), max(col, clip[2])
    r1, c1 = min(row + mask.shape[0], clip[1]), min(col + mask.shape[1], clip[3])
    if r0 >= r1 or c0 >= c1:
        return
    mask = mask[r0 - row:r1 - row, c0 - col:c1 - col]
    if hidden is not None:
        mask = mask & ~hidden[r0:r1, c0:c1]
    image[r0:r1, c0:c1][mask] = colour


def darken(region: np.ndarray, keep: float) -> None:
    """Blends `region` in place with black, keeping the fraction `keep` (a translucent black box)."""
    if keep == 0.5:
        np.right_shift(region, 1, out=region)
    else:
        region[...] = (region * keep).astype(np.uint8)


def banner(image: np.ndarray, font: BitmapFont, text: str, colour, centre: int, bottom: int) -> None:
    """One line of `text` in `font` and `colour` (RGB in [0, 1]) on a darkened box, centred on column `centre`, the
    box's lower edge `bottom` pixels above the image's (OpenGL rows, as `BitmapFont.text`): the event banner of the
    planar and the 6-DOF frames."""
    text_w, text_h = font.width(text), font.height
    pad = text_h // 2
    left, width, height = centre - text_w // 2 - pad, text_w + 2 * pad, text_h + 2 * pad
    top = image.shape[0] - bottom - height
    darken(image[max(top, 0):top + height, max(left, 0):left + width], 0.4)
    font.text(image, text, left + pad, bottom + pad, np.floor(np.asarray(colour) * 255))


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
        self._blocks: dict[str, np.ndarray] = {}

    def width(self, text: str) -> int:
        """Width [px] of one line of text."""
        return self.mask(text).shape[1]

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

    def _block(self, text: str) -> tuple[np.ndarray, np.ndarray, int, int]:
        """The lit pixels (rows, columns) of a column of text as `mjr_overlay` lays it out in its box, and
        the box's height and width (cached: the labels never change)."""
        block = self._blocks.get(text)
        if block is None:
            pad, lines = OVERLAY_PAD, text.split("\n")
            masks = [self.mask(line) for line in lines]
            lit = [np.nonzero(mask) for mask in masks]  # line i starts i line pitches below the box's top
            rows = np.concatenate([r + i * (pad + self.height) for i, (r, _) in enumerate(lit)])
            cols = np.concatenate([c + 3 for _, c in lit])
            block = (rows, cols, pad + len(lines) * self.height + (len(lines) - 1) * pad,
                     pad + max(m.shape[1] for m in masks) + 8)
            if len(self._blocks) > 256:
                self._blocks.clear()
            self._blocks[text] = block
        return block

    def _column(self, image: np.ndarray, gridpos: int, viewport, skip: int, text: str, colour) -> int:
        pad, (rows, cols, height, width) = OVERLAY_PAD, self._block(text)
        vl, vb, vw, vh = viewport
        top = gridpos in (mujoco.mjtGridPos.mjGRID_TOPLEFT, mujoco.mjtGridPos.mjGRID_TOPRIGHT)
        left_side = gridpos in (mujoco.mjtGridPos.mjGRID_TOPLEFT, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT)
        left = vl + skip + pad if left_side else vl + vw - skip - 1 - pad - width
        bottom = vb + vh - 1 - pad - height if top else vb + pad
        h, w = image.shape[:2]
        row = h - bottom - height
        r0, r1 = max(row, 0), min(row + height, h)
        c0, c1 = max(left, 0), min(left + width, w)
        if r0 < r1 and c0 < c1:
            darken(image[r0:r1, c0:c1], 0.5)
            rows, cols = rows + row, cols + left
            if row < 0 or left < 0 or row + height > h or left + width > w:
                inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
                rows, cols = rows[inside], cols[inside]
            image[rows, cols] = colour
        return width - 2
