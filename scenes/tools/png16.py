"""Minimal 16-bit greyscale PNG writer and reader (numpy + zlib only).

Used by the scene-data scripts so that they need nothing beyond Debian's
python3-numpy: run them with /usr/bin/python3 (Debian's interpreter), not a
`python3` found earlier on PATH.
"""
import struct
import zlib

import numpy as np


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
    return np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))


def write_png16(path: str, img: np.ndarray) -> None:
    """Writes a 2D array of uint16 as a 16-bit greyscale PNG (row 0 = first scanline).

    Each row gets the PNG filter (None, Sub, Up, Average, Paeth) with the smallest sum
    of absolute filtered bytes, as libpng's heuristic does; this matters for size."""
    img = np.asarray(img)
    if img.ndim != 2 or img.dtype != np.uint16:
        raise ValueError("expected a 2D uint16 array")
    h, w = img.shape
    raw = img.astype(">u2").view(np.uint8).reshape(h, 2 * w).astype(np.int32)
    bpp = 2
    out = bytearray()
    prev = np.zeros(2 * w, dtype=np.int32)
    for row in raw:
        left = np.concatenate([np.zeros(bpp, np.int32), row[:-bpp]])
        upleft = np.concatenate([np.zeros(bpp, np.int32), prev[:-bpp]])
        candidates = [
            row,
            row - left,
            row - prev,
            row - (left + prev) // 2,
            row - _paeth(left, prev, upleft),
        ]
        candidates = [c & 0xFF for c in candidates]
        cost = [np.abs(c.astype(np.int8).astype(np.int32)).sum() for c in candidates]
        f = int(np.argmin(cost))
        out.append(f)
        out += candidates[f].astype(np.uint8).tobytes()
        prev = row
    ihdr = struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)
    data = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(bytes(out), 9)) + _chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(data)


def read_png16(path: str) -> np.ndarray:
    """Reads back what write_png16 writes (16-bit greyscale, not interlaced)."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, b""
    w = h = None
    while pos < len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 16 and ctype == 0, "only 16-bit greyscale"
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 2 * w)
    rows = np.zeros((h, 2 * w), np.int32)
    prev = np.zeros(2 * w, np.int32)
    for j in range(h):
        f, line = raw[j, 0], raw[j, 1:].astype(np.int32)
        cur = np.zeros(2 * w, np.int32)
        for i in range(2 * w):  # slow but only used to check
            a = cur[i - 2] if i >= 2 else 0
            b = prev[i]
            c = prev[i - 2] if i >= 2 else 0
            pred = [0, a, b, (a + b) // 2, int(_paeth(np.int32(a), np.int32(b), np.int32(c)))][f]
            cur[i] = (line[i] + pred) & 0xFF
        rows[j] = cur
        prev = cur
    return (rows[:, 0::2] * 256 + rows[:, 1::2]).astype(np.uint16)
