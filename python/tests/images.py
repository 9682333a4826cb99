"""Small image readers for the tests, so that pictures are compared
without an image library: OpenEXR (scan-line files of float32 or half
channels in scan lines or tiles, uncompressed, RLE or ZIP compressed:
what ``arbor render`` writes) and 8-bit RGB PNG."""

import struct
import zlib

import numpy as np


def _attributes(data):
    """The header attributes {name: (type, bytes)} and where they end."""
    pos, out = 8, {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        tend = data.index(b"\0", end + 1)
        kind = data[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", data, tend + 1)
        out[name] = (kind, data[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return out, pos + 1


def _channels(raw):
    """[(name, pixel type)] of a chlist attribute, in file order."""
    out, pos = [], 0
    while raw[pos] != 0:
        end = raw.index(b"\0", pos)
        (ptype,) = struct.unpack_from("<i", raw, end + 1)
        out.append((raw[pos:end].decode(), ptype))
        pos = end + 17
    return out


def _unpredict(buf):
    """Undoes the byte delta and the interleaving of RLE and ZIP blocks."""
    d = np.frombuffer(buf, np.uint8).astype(np.int64)
    b = ((d[0] + np.cumsum(np.concatenate([[0], d[1:] - 128]))) % 256).astype(np.uint8)
    half = (len(b) + 1) // 2
    out = np.empty_like(b)
    out[0::2], out[1::2] = b[:half], b[half:]
    return out.tobytes()


def _unrle(buf):
    out, i = bytearray(), 0
    while i < len(buf):
        n = struct.unpack_from("<b", buf, i)[0]
        i += 1
        if n < 0:
            out += buf[i:i - n]
            i -= n
        else:
            out += bytes([buf[i]]) * (n + 1)
            i += 1
    return bytes(out)


def read_exr(path):
    """The image at `path` as a (h, w, 3) float32 array of R, G, B: scan
    lines, or one level of tiles (as the exr crate writes)."""
    data = open(path, "rb").read()
    assert data[:4] == b"\x76\x2f\x31\x01", f"{path}: not an OpenEXR file"
    attrs, pos = _attributes(data)
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    compression = attrs["compression"][1][0]
    channels = _channels(attrs["channels"][1])
    dtypes = {1: np.dtype("<f2"), 2: np.dtype("<f4")}
    if "tiles" in attrs:
        tw, th = struct.unpack_from("<II", attrs["tiles"][1])
        header, chunks = 20, ((w + tw - 1) // tw) * ((h + th - 1) // th)
    else:
        tw, th = w, {0: 1, 1: 1, 2: 1, 3: 16}[compression]
        header, chunks = 8, (h + th - 1) // th
    offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
    planes = {name: np.zeros((h, w), np.float32) for name, _ in channels}
    for off in offsets:
        if "tiles" in attrs:
            tx, ty = struct.unpack_from("<ii", data, off)
            bx, by = tx * tw, ty * th
        else:
            bx, by = 0, struct.unpack_from("<i", data, off)[0] - y0
        (size,) = struct.unpack_from("<i", data, off + header - 4)
        block = data[off + header:off + header + size]
        cols, rows = min(tw, w - bx), min(th, h - by)
        raw = rows * sum(cols * dtypes[t].itemsize for _, t in channels)
        if size < raw:  # stored as is when compression did not pay
            block = _unrle(block) if compression == 1 else zlib.decompress(block)
            block = _unpredict(block)
        at = 0
        for row in range(by, by + rows):
            for name, t in channels:
                count = cols * dtypes[t].itemsize
                planes[name][row, bx:bx + cols] = np.frombuffer(block[at:at + count], dtypes[t])
                at += count
    return np.stack([planes["R"], planes["G"], planes["B"]], axis=-1)


def read_png(path):
    """An 8-bit RGB, non-interlaced PNG as a (h, w, 3) uint8 array."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG file"
    pos, idat = 8, b""
    while pos < len(data):
        (size,) = struct.unpack_from(">I", data, pos)
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + size]
        if kind == b"IHDR":
            w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, colour, interlace) == (8, 2, 0), f"{path}: not 8-bit RGB"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + size
    raw = zlib.decompress(idat)
    stride, bpp = 3 * w, 3
    out = np.zeros((h, stride), np.int64)
    prev = np.zeros(stride, np.int64)
    for y in range(h):
        kind = raw[y * (stride + 1)]
        line = np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int64)
        cur = np.zeros(stride, np.int64)
        for i in range(stride):
            a = cur[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if kind == 0:
                p = 0
            elif kind == 1:
                p = a
            elif kind == 2:
                p = b
            elif kind == 3:
                p = (a + b) // 2
            else:  # Paeth
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[i] = (line[i] + p) % 256
        out[y], prev = cur, cur
    return out.reshape(h, w, 3).astype(np.uint8)
