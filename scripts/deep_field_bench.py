#!/usr/bin/env python3
"""Times `arbor render` on the deep field (scripts/deep_field.py) against
its depth: wall time and peak memory (GNU time's maximum resident set) for
each --instancing mode and L, as a Markdown table; flat is skipped past its
placement limit. Checks that every mode writes the same bytes.

  deep_field_bench.py [--arbor PATH] [--levels 1-9] [--modes flat,nested,auto]
                      [--plot FILE.svg] [--from-table FILE.md]

--from-table reads a table this script printed (in a Markdown file, e.g.
the perf log) instead of rendering. --plot also draws the table: time and peak memory against L, one line per
mode, memory on a log scale (flat's grows 100-fold a level, nested's not).
"""
import argparse
import filecmp
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
FLAT_LIMIT = 1 << 22  # DEFAULT_MAX_PLACEMENTS


def run(arbor, scene, out, mode):
    """(wall seconds, peak MiB) of one render, or None when it fails."""
    cmd = ["/usr/bin/time", "-v", arbor, "render", scene, "-o", out,
           "--instancing", mode, "--quiet"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return None
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", p.stderr)
    h, m, s = wall.groups()
    seconds = int(h or 0) * 3600 + int(m) * 60 + float(s)
    kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr).group(1))
    return seconds, kb / 1024


COLOURS = {"flat": "#c0392b", "nested": "#2471a3", "auto": "#229954"}


def svg_plot(rows, modes, path):
    """Writes an SVG of `rows` ({L: {mode: (seconds, MiB)}}): two panels
    against L, wall time (linear from 0) and peak memory (log 10)."""
    levels = sorted(rows)
    w, h, pad = 360, 240, 48
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * w}" height="{h}" '
           'font-family="sans-serif" font-size="11">',
           f'<rect width="{2 * w}" height="{h}" fill="white"/>']
    for k, (title, log) in enumerate([("wall time (s)", False), ("peak memory (MiB, log scale)", True)]):
        x0 = k * w
        vals = [rows[L][m][k] for L in levels for m in modes if m in rows[L]]
        lo, hi = (min(vals) / 1.5, max(vals) * 1.5) if log else (0.0, max(vals) * 1.1)
        scale = math.log10 if log else (lambda v: v)

        def px(L, v):
            x = x0 + pad + (L - levels[0]) / max(1, levels[-1] - levels[0]) * (w - 2 * pad)
            y = h - pad - (scale(v) - scale(lo)) / (scale(hi) - scale(lo)) * (h - 2 * pad)
            return x, y

        out.append(f'<text x="{x0 + w / 2}" y="16" text-anchor="middle">{title}</text>')
        out.append(f'<path d="M{x0 + pad},{pad} V{h - pad} H{x0 + w - pad}" fill="none" stroke="black"/>')
        for L in levels:
            out.append(f'<text x="{px(L, lo)[0]:.1f}" y="{h - pad + 14}" text-anchor="middle">{L}</text>')
        out.append(f'<text x="{x0 + w / 2}" y="{h - 12}" text-anchor="middle">L (10^2L bunnies)</text>')
        ticks = [lo, math.sqrt(lo * hi), hi] if log else [lo, hi / 2, hi]
        for v in ticks:
            out.append(f'<text x="{x0 + pad - 4}" y="{px(levels[0], v)[1] + 4:.1f}" text-anchor="end">{v:.3g}</text>')
        for i, m in enumerate(modes):
            pts = [px(L, rows[L][m][k]) for L in levels if m in rows[L]]
            colour = COLOURS.get(m, "black")
            if pts:
                line = " ".join(f"{x:.1f},{y:.1f}" for x, y in pts)
                out.append(f'<polyline points="{line}" fill="none" stroke="{colour}" stroke-width="2"/>')
            out.append(f'<text x="{x0 + w - pad - 40}" y="{pad + 14 * i}" fill="{colour}">{m}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def read_table(path):
    """(modes, {L: {mode: (seconds, MiB)}}) from the first table in `path`
    whose header this script writes; `-` cells are left out."""
    lines = open(path).read().splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith("| L | bunnies |"))
    header = [c.strip() for c in lines[start].strip("|").split("|")]
    modes = [c[:-2] for c in header[2:-1:2]]
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        for k, m in enumerate(modes):
            t, mib = cells[2 + 2 * k], cells[3 + 2 * k]
            if t != "-":
                rows.setdefault(int(cells[0]), {})[m] = (float(t), float(mib))
    return modes, rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arbor", default=os.path.join(HERE, "..", "target", "release", "arbor"))
    ap.add_argument("--levels", default="1-9")
    ap.add_argument("--modes", default="flat,nested,auto")
    ap.add_argument("--plot", help="also draw the table as this SVG file")
    ap.add_argument("--from-table", help="plot the first such table in this Markdown file")
    a = ap.parse_args()
    if a.from_table:
        modes, rows = read_table(a.from_table)
        if a.plot:
            svg_plot(rows, modes, a.plot)
        return
    rows = {}
    lo, _, hi = a.levels.partition("-")
    levels = range(int(lo), int(hi or lo) + 1)
    modes = a.modes.split(",")
    print("| L | bunnies | " + " | ".join(f"{m} s | {m} MiB" for m in modes) + " | same bytes |")
    print("| --- | --- | " + " | ".join("--- | ---" for _ in modes) + " | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for L in levels:
            scene = os.path.join(tmp, f"deep{L}.xml")
            subprocess.run([sys.executable, os.path.join(HERE, "deep_field.py"), str(L),
                            "-o", scene], check=True, capture_output=True)
            cells, pictures = [], []
            for m in modes:
                out = os.path.join(tmp, f"deep{L}-{m}.png")
                r = None if (m == "flat" and 100 ** L > FLAT_LIMIT) else run(a.arbor, scene, out, m)
                if r is None:
                    cells.append("- | -")
                else:
                    cells.append(f"{r[0]:.2f} | {r[1]:.0f}")
                    pictures.append(out)
                    rows.setdefault(L, {})[m] = r
            same = all(filecmp.cmp(pictures[0], p, shallow=False) for p in pictures[1:])
            print(f"| {L} | 10^{2 * L} | " + " | ".join(cells) + f" | {'yes' if same else 'NO'} |",
                  flush=True)
    if a.plot:
        svg_plot(rows, modes, a.plot)


if __name__ == "__main__":
    main()
