"""Video files: frames streamed to an H.264 MP4 (through imageio-ffmpeg) or an animated GIF (through Pillow).

Both writers take any iterable of (H, W, 3) uint8 frames and write them as they come, so a long episode never sits
in memory. They know nothing of episodes or of what a frame shows: the planar and the 6-DOF videos
(`auv_mj.render.episode_video`, `auv_mj.render.episode_video3d`) and the commands that draw frames of their own
(`auv-mj demo`, `record-failures`) all write through `write_video`.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path

import numpy as np

DEFAULT_FPS = 30
"""Frame rate of the videos [frames/s]."""
VIDEO_SUFFIXES = (".mp4", ".gif")
"""The video files `write_video` writes: H.264 MP4 or animated GIF."""


def ffmpeg_available() -> bool:
    """Whether imageio-ffmpeg can find an ffmpeg binary."""
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
        return True
    except (ImportError, RuntimeError):
        return False


def write_video(frames: Iterable[np.ndarray], path: str | Path, fps: float = DEFAULT_FPS,
                gif: bool | None = None) -> Path:
    """Writes frames to `path`: H.264 MP4 (yuv420p), or GIF when asked, named .gif, or without ffmpeg.

    Frames stream to the file as they come (to ffmpeg for an MP4, to Pillow's GIF encoder frame by frame): a long
    episode never sits in memory.
    Returns the path written (its suffix is .gif when it fell back to GIF).
    """
    path = Path(path)
    gif = path.suffix.lower() == ".gif" if gif is None else gif
    if not gif and not ffmpeg_available():
        warnings.warn("no ffmpeg binary (imageio-ffmpeg) found: writing a GIF instead of an MP4",
                      stacklevel=2)
        gif = True
    if gif and path.suffix.lower() != ".gif":
        path = path.with_suffix(".gif")
    path.parent.mkdir(parents=True, exist_ok=True)
    if gif:
        return _write_gif(frames, path, fps)
    import imageio_ffmpeg

    writer = None
    try:
        for frame in frames:
            if writer is None:
                h, w = frame.shape[:2]
                if h % 2 or w % 2:
                    raise ValueError(f"H.264 (yuv420p) needs even frame sizes, got {w} x {h}")
                writer = imageio_ffmpeg.write_frames(
                    str(path), (w, h), fps=fps, codec="libx264", pix_fmt_out="yuv420p", quality=7,
                    macro_block_size=1, output_params=["-preset", "veryfast"])
                writer.send(None)
            writer.send(np.ascontiguousarray(frame))
    finally:
        if writer is not None:
            writer.close()
    if writer is None:
        raise ValueError("no frames to write")
    return path


def _write_gif(frames: Iterable[np.ndarray], path: Path, fps: float) -> Path:
    """An animated GIF (looping) written frame by frame as the frames come, each with its own 256-colour palette:
    memory flat in the video's length, as for an MP4."""
    from PIL import GifImagePlugin, Image

    duration = 1000.0 / fps  # [ms]; GIF keeps hundredths of a second
    written = False
    with open(path, "wb") as f:
        for frame in frames:
            image = Image.fromarray(np.ascontiguousarray(frame)).quantize(256)
            if not written:
                header, _ = GifImagePlugin.getheader(image, info={"loop": 0, "duration": duration})
                f.write(b"".join(header))
                written = True
            f.write(b"".join(GifImagePlugin.getdata(image, duration=duration, include_color_table=True)))
        f.write(b";")  # the trailer
    if not written:
        path.unlink()
        raise ValueError("no frames to write")
    return path
