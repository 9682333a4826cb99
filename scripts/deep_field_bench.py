#!/usr/bin/env python3
"""Times `arbor render` on the deep field (scripts/deep_field.py) against
its depth: wall time and peak memory (GNU time's maximum resident set) for
each --instancing mode and L, as a Markdown table; flat is skipped past its
placement limit. Checks that every mode writes the same bytes.

  deep_field_bench.py [--arbor PATH] [--levels 1-9] [--modes flat,nested,auto]
"""
import argparse
import filecmp
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arbor", default=os.path.join(HERE, "..", "target", "release", "arbor"))
    ap.add_argument("--levels", default="1-9")
    ap.add_argument("--modes", default="flat,nested,auto")
    a = ap.parse_args()
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
            same = all(filecmp.cmp(pictures[0], p, shallow=False) for p in pictures[1:])
            print(f"| {L} | 10^{2 * L} | " + " | ".join(cells) + f" | {'yes' if same else 'NO'} |",
                  flush=True)


if __name__ == "__main__":
    main()
