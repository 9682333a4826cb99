#!/usr/bin/env python3
"""A contact sheet of every model arbor reads in a folder tree (by default
Debian's assimp-testmodels): each OBJ, PLY, STL, glTF and GLB file rendered
small by arbor, composed into one PNG with the file names under the
thumbnails. Files arbor refuses show as a dark cell with their name, in red.

Standard library only: PNG is read and written with zlib, the names are
drawn with a 3x5 pixel font of the characters file names use.

    python3 scripts/contact-sheet.py --arbor target/release/arbor \
        -o docs/images/contact-sheet.png
"""

import argparse
import os
import struct
import subprocess
import sys
import tempfile
import zlib

EXTENSIONS = (".obj", ".ply", ".stl", ".gltf", ".glb")

# 3x5 glyphs, five rows of three cells ('#' on), top to bottom. Letters
# are drawn in capitals.
FONT = {
    "A": ".#./#.#/###/#.#/#.#", "B": "##./#.#/##./#.#/##.", "C": ".##/#../#../#../.##",
    "D": "##./#.#/#.#/#.#/##.", "E": "###/#../##./#../###", "F": "###/#../##./#../#..",
    "G": ".##/#../#.#/#.#/.##", "H": "#.#/#.#/###/#.#/#.#", "I": "###/.#./.#./.#./###",
    "J": "..#/..#/..#/#.#/.#.", "K": "#.#/#.#/##./#.#/#.#", "L": "#../#../#../#../###",
    "M": "#.#/###/###/#.#/#.#", "N": "##./#.#/#.#/#.#/#.#", "O": ".#./#.#/#.#/#.#/.#.",
    "P": "##./#.#/##./#../#..", "Q": ".#./#.#/#.#/##./.##", "R": "##./#.#/##./#.#/#.#",
    "S": ".##/#../.#./..#/##.", "T": "###/.#./.#./.#./.#.", "U": "#.#/#.#/#.#/#.#/###",
    "V": "#.#/#.#/#.#/#.#/.#.", "W": "#.#/#.#/###/###/#.#", "X": "#.#/#.#/.#./#.#/#.#",
    "Y": "#.#/#.#/.#./.#./.#.", "Z": "###/..#/.#./#../###", "0": "###/#.#/#.#/#.#/###",
    "1": ".#./##./.#./.#./###", "2": "##./..#/.#./#../###", "3": "##./..#/.#./..#/##.",
    "4": "#.#/#.#/###/..#/..#", "5": "###/#../##./..#/##.", "6": ".##/#../###/#.#/###",
    "7": "###/..#/.#./.#./.#.", "8": "###/#.#/###/#.#/###", "9": "###/#.#/###/..#/##.",
    ".": ".../.../.../.../.#.", "_": ".../.../.../.../###", "-": ".../.../###/.../...",
    "/": "..#/..#/.#./#../#..", "(": ".#./#../#../#../.#.", ")": ".#./..#/..#/..#/.#.",
    " ": ".../.../.../.../...",
}


def glyph(ch):
    """The 15 cells of `ch` (unknown characters as `_`)."""
    return FONT.get(ch.upper(), FONT["_"]).replace("/", "")


def read_png(path):
    """(width, height, rows of RGB bytes) of an 8-bit RGB or RGBA PNG."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            if depth != 8 or colour not in (2, 6):
                raise ValueError("only 8-bit RGB or RGBA")
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        prev = line
        if bpp == 4:
            line = bytearray(v for i, v in enumerate(line) if i % 4 != 3)
        rows.append(line)
    return width, height, rows


def write_png(path, width, height, pixels):
    """Writes `pixels` (a bytearray of RGB rows) as an 8-bit RGB PNG."""
    raw = b"".join(b"\x00" + bytes(pixels[y * width * 3:(y + 1) * width * 3])
                   for y in range(height))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(png)
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--arbor", default="target/release/arbor")
    ap.add_argument("--models", default="/usr/share/assimp/models")
    ap.add_argument("-o", "--output", default="docs/images/contact-sheet.png")
    ap.add_argument("--size", default="128x96", help="thumbnail WxH")
    ap.add_argument("--columns", type=int, default=10)
    ap.add_argument("--timeout", type=float, default=120)
    args = ap.parse_args()
    tw, th = (int(v) for v in args.size.split("x"))
    files = sorted(
        os.path.join(d, f)
        for d, _, fs in os.walk(args.models)
        for f in fs
        if f.lower().endswith(EXTENSIONS)
    )
    if not files:
        sys.exit(f"{args.models}: no model files")
    label_h, scale = 8, 1
    cell_w, cell_h = tw + 4, th + label_h + 4
    cols = args.columns
    rows = (len(files) + cols - 1) // cols
    width, height = cols * cell_w, rows * cell_h
    sheet = bytearray(b"\x20" * (width * height * 3))

    def put(x, y, rgb):
        if 0 <= x < width and 0 <= y < height:
            sheet[(y * width + x) * 3:(y * width + x) * 3 + 3] = bytes(rgb)

    def text(x, y, s, rgb):
        for k, ch in enumerate(s):
            g = glyph(ch)
            for r in range(5):
                for c in range(3):
                    if g[r * 3 + c] == "#":
                        for dy in range(scale):
                            for dx in range(scale):
                                put(x + (k * 4 + c) * scale + dx, y + r * scale + dy, rgb)

    failed = []
    with tempfile.TemporaryDirectory() as tmp:
        for n, path in enumerate(files):
            x0, y0 = (n % cols) * cell_w + 2, (n // cols) * cell_h + 2
            out = os.path.join(tmp, f"{n}.png")
            name = os.path.relpath(path, args.models)
            try:
                run = subprocess.run(
                    [args.arbor, "render", path, "-o", out, "-q",
                     "--size", f"{tw}x{th}", "--spp", "1"],
                    capture_output=True, text=True, timeout=args.timeout)
                ok = run.returncode == 0 and os.path.exists(out)
                why = run.stderr.strip().splitlines()[-1:] if not ok else []
            except subprocess.TimeoutExpired:
                ok, why = False, ["timed out"]
            if ok:
                w, h, img = read_png(out)
                for y in range(min(h, th)):
                    start = ((y0 + y) * width + x0) * 3
                    sheet[start:start + min(w, tw) * 3] = img[y][:min(w, tw) * 3]
            else:
                failed.append((name, why[0] if why else "no image"))
                for y in range(th):
                    for x in range(tw):
                        put(x0 + x, y0 + y, (70, 40, 40))
            label = os.path.basename(path)
            fit = tw // 4
            if len(label) > fit:
                label = label[:fit - 1] + "-"
            text(x0, y0 + th + 2, label, (235, 235, 235) if ok else (255, 110, 110))
            print(f"{'ok ' if ok else 'BAD'} {name}", file=sys.stderr)
    write_png(args.output, width, height, sheet)
    print(f"{args.output}: {len(files)} models, {len(failed)} refused", file=sys.stderr)
    for name, why in failed:
        print(f"  refused: {name}: {why}", file=sys.stderr)


if __name__ == "__main__":
    main()
