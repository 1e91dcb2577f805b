"""Reading images from disk with one clear error per bad file, and atomic product writes."""

from __future__ import annotations

import contextlib
import functools
import os
import struct
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

__all__ = [
    "MAX_PIXELS",
    "ImageError",
    "as_bgr8",
    "encode_image",
    "read_image",
    "write_atomic",
    "write_jpeg",
    "write_png",
]

MAX_PIXELS = 400_000_000
"""Refuse images above this many pixels (an 8000x4000 panorama is 32 M)."""


class ImageError(ValueError):
    """A file that cannot be analysed; the message names the file and the reason."""


def _png_size(head: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG header, read before decoding (decompression bombs)."""
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        return struct.unpack(">II", head[16:24])
    return None


def _truncated(data: bytes) -> str | None:
    r"""Which format the file claims and ends before finishing, if so: a cut-off copy or
    download decodes to grey (JPEG) or not at all (PNG), and should be called what it is.

    >>> _truncated(b"\xff\xd8\xff\xe0 ... "), _truncated(b"\xff\xd8 ... \xff\xd9\x00")
    ('JPEG', None)
    """
    if data[:2] == b"\xff\xd8" and b"\xff\xd9" not in data[-64:]:
        return "JPEG"  # no end-of-image marker (some writers pad after it)
    if data[:8] == b"\x89PNG\r\n\x1a\n" and b"IEND" not in data[-64:]:
        return "PNG"  # no closing IEND chunk
    return None


@contextlib.contextmanager
def _native_stderr() -> Iterator[list[str]]:
    """The lines C libraries write to file descriptor 2 meanwhile: libjpeg and libpng say
    "Corrupt JPEG data" or "libpng error" there, not to OpenCV's caller, and an unattributed
    line on the console names no file. Captured, they become the file's error."""
    said: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with tempfile.TemporaryFile() as tmp:
            os.dup2(tmp.fileno(), 2)
            try:
                yield said
            finally:
                os.dup2(saved, 2)
                tmp.seek(0)
                said.extend(line for line in tmp.read().decode(errors="replace").splitlines())
    finally:
        os.close(saved)


def read_image(path: str | os.PathLike[str], max_pixels: int = MAX_PIXELS) -> np.ndarray:
    """Decode an image file as-is (any depth and channel count OpenCV reads).

    Raises ImageError for a missing, unreadable, empty, truncated, corrupt, non-image or
    oversized file.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise ImageError(f"{p}: no such file") from None
    except IsADirectoryError:
        raise ImageError(f"{p}: is a directory") from None
    except OSError as exc:
        raise ImageError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if not data:
        raise ImageError(f"{p}: empty file")
    size = _png_size(data[:24])
    if size and size[0] * size[1] > max_pixels:
        raise ImageError(f"{p}: {size[0]}x{size[1]} is too large (limit {max_pixels} pixels)")
    cut = _truncated(data)
    if cut:
        raise ImageError(f"{p}: truncated {cut} file: it ends before the image does")
    try:
        with _native_stderr() as said:
            img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise ImageError(f"{p}: cannot decode: {str(exc).strip().splitlines()[-1]}") from None
    if said:  # decoded with damage (a flipped bit) or not at all: the library says why
        raise ImageError(f"{p}: corrupt image data: {'; '.join(said)}")
    if img is None or img.size == 0:
        raise ImageError(f"{p}: not an image in a format OpenCV can read")
    if img.shape[0] * img.shape[1] > max_pixels:
        raise ImageError(
            f"{p}: {img.shape[1]}x{img.shape[0]} is too large (limit {max_pixels} pixels)"
        )
    return img


@functools.cache
def _file_mode() -> int:
    """What ``open()`` would give a new file: 0666 less the umask. A temporary file is
    made 0600, which under systemd (user cyborg, UMask=0027) would keep the geologist's
    own account out of the results; this makes them 0640, readable by group cyborg."""
    mask = os.umask(0o022)  # read it (the only way before Linux's /proc Umask line)
    os.umask(mask)
    return 0o666 & ~mask


def fsync_path(path: Path) -> None:
    """Put a file's data, or a folder's entries, on the disk: a rename in the folder
    survives a power cut."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomic(path: Path, data: bytes, sync: bool = True) -> None:
    """Write a file so that readers see the old file or the whole new one, never a part;
    ``sync=False`` leaves it to the caller to fsync (many files at once, then a mark)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        os.fchmod(fd, _file_mode())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            if sync:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def encode_image(image: np.ndarray, ext: str = ".jpg", quality: int = 90) -> bytes:
    """The ``.jpg`` (at ``quality``) or ``.png`` bytes of an image; b"" if OpenCV cannot
    encode it (each caller says what a missing image means: a chip without a preview, a
    live frame skipped, a file not written).

    >>> black = np.zeros((8, 8, 3), np.uint8)
    >>> encode_image(black)[:2], encode_image(black, ".png")[1:4]
    (b'\\xff\\xd8', b'PNG')
    """
    flags = [cv2.IMWRITE_JPEG_QUALITY, quality] if ext == ".jpg" else []
    ok, buf = cv2.imencode(ext, image, flags)
    return buf.tobytes() if ok else b""


def write_png(path: Path, image: np.ndarray, sync: bool = True) -> None:
    """Encode and write a PNG atomically (``sync``: as :func:`write_atomic`)."""
    _write_encoded(path, image, ".png", sync=sync)


def write_jpeg(path: Path, image: np.ndarray, quality: int = 90, sync: bool = True) -> None:
    """Encode and write a JPEG atomically (photographs of many megapixels)."""
    _write_encoded(path, image, ".jpg", quality, sync)


def _write_encoded(
    path: Path, image: np.ndarray, ext: str, quality: int = 90, sync: bool = True
) -> None:
    data = encode_image(image, ext, quality)
    if not data:
        raise OSError(f"{path}: {ext[1:].upper()} encoding failed")
    write_atomic(path, data, sync)


def as_bgr8(image: np.ndarray) -> np.ndarray:
    """Bring any decoded image to (M, N, 3) uint8 BGR: grey, alpha and 16-bit welcome.

    Examples
    --------
    >>> as_bgr8(np.full((2, 2), 65535, np.uint16))[0, 0].tolist()
    [255, 255, 255]
    >>> as_bgr8(np.zeros((1, 1, 4), np.uint8)).shape
    (1, 1, 3)
    """
    if image.ndim not in (2, 3) or image.size == 0:
        raise ValueError(f"not an image: shape {image.shape}")
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    elif image.dtype in (np.float32, np.float64):
        image = np.clip(np.nan_to_num(image) * 255.0, 0, 255).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise ValueError(f"unsupported pixel type {image.dtype}")
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    channels = image.shape[2]
    if channels == 1:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if channels == 3:
        return np.ascontiguousarray(image)
    if channels == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    raise ValueError(f"unsupported channel count {channels}")
