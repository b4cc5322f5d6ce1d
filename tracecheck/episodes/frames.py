"""Decompressing what a run file holds — its zstd chunks, columns attachments and run blobs,
and the lz4 chunks other MCAP tools may write — with every limit checked before the work it
limits.

The record around a frame says how many bytes it holds (an MCAP chunk's uncompressed size, a
columns blob's size field); its caller has checked that number against tracecheck's limits.
A zstd frame may declare a size of its own in its header, and python-zstandard allocates
what the frame declares whatever ``max_output_size`` it is given: so the frame's declaration
is read first and must be the record's, and only then is anything decompressed (into at most
the record's size, with a window no larger than that); the output must then be exactly that
size. A frame that does not fit is refused without a byte decompressed.
"""

from __future__ import annotations

import threading

__all__ = ["unzstd", "unlz4", "zstd"]

#: the smallest window a frame may always use (zstd's own frames for small data use less)
_MIN_WINDOW = 1 << 20


#: zstd's own limit on a frame's window where nothing else bounds it (128 MiB; the output
#: is still bounded by the size the record declares)
_DEFAULT_WINDOW = 1 << 27

_LOCAL = threading.local()  # a thread's decompressors, by window (one costs 14 µs to make)


def _decompressor(zstandard, size: int):
    """A zstd decompressor of this thread whose frames may ask for a window of at most the
    power of two at or above ``size``, at least 1 MiB."""
    window = max(_MIN_WINDOW, 1 << max(size - 1, 1).bit_length())
    return _kept("decompressors", window,
                 lambda: zstandard.ZstdDecompressor(max_window_size=window))


def _kept(kind: str, key: int, make):
    """This thread's object of ``kind`` for ``key``, made once (zstd's objects are not to be
    shared between threads)."""
    made = getattr(_LOCAL, kind, None)
    if made is None:
        made = {}
        setattr(_LOCAL, kind, made)
    found = made.get(key)
    if found is None:
        found = made[key] = make()
    return found


def zstd(data: bytes, level: int = 3) -> bytes:
    """``data`` compressed as one zstd frame at ``level``: ``zstandard.compress``'s bytes,
    by a compressor this thread keeps (making one for each chunk of a recording cost more
    than compressing a small chunk)."""
    import zstandard

    return _kept("compressors", level, lambda: zstandard.ZstdCompressor(level=level)
                 ).compress(data)


def unzstd(data: bytes, size: int, what: str) -> bytes:
    """``data`` (one zstd frame) decompressed, where the record around it declares ``size``
    bytes (``what``: that record in a message, "a chunk", "it").

    Raises:
        ImportError: the zstandard package is not installed.
        ValueError: the frame declares another size (nothing decompressed), does not
            decompress, or decompresses to another size; the message says which.
    """
    import zstandard

    try:
        declared = zstandard.frame_content_size(data)
    except zstandard.ZstdError:
        raise ValueError(f"{what} is not a zstd frame (its header does not read)") from None
    if declared not in (-1, size):  # -1: the frame does not say; the output is bounded
        raise ValueError(f"{what} declares {size} bytes but its zstd frame {declared}: "
                         "refused before decompressing (a decompression bomb, or damage)")
    try:  # a frame that does not say its size (a streaming writer's, with its own window):
        #     the output is bounded, the window is zstd's default limit
        window = size if declared == size else _DEFAULT_WINDOW
        out = _decompressor(zstandard, window).decompress(data, max_output_size=max(size, 1))
    except zstandard.ZstdError as exc:
        raise ValueError(f"{what} does not decompress (zstd): {exc}") from None
    if len(out) != size:
        raise ValueError(f"{what} decompresses to {len(out)} bytes, not the {size} it "
                         "declares")
    return out


def unlz4(data: bytes, size: int, what: str) -> bytes:
    """``data`` (one lz4 frame) decompressed, where the record ``what`` around it declares
    ``size`` bytes: the frame's own declaration (where it has one) checked first, at most ``size +
    1`` bytes decompressed (one more than declared: the record lied).

    Raises:
        ImportError: the lz4 package is not installed.
        ValueError: as :func:`unzstd`.
    """
    import lz4.frame

    try:
        declared = lz4.frame.get_frame_info(data).get("content_size", 0)
    except (RuntimeError, ValueError):
        raise ValueError(f"{what} is not an lz4 frame (its header does not read)") from None
    if declared and declared != size:  # 0: the frame does not say
        raise ValueError(f"{what} declares {size} bytes but its lz4 frame {declared}: "
                         "refused before decompressing (a decompression bomb, or damage)")
    try:
        out = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
    except RuntimeError as exc:
        raise ValueError(f"{what} does not decompress (lz4): {exc}") from None
    if len(out) != size:
        raise ValueError(f"{what} decompresses to {len(out)} bytes, not the {size} it "
                         "declares")
    return out
