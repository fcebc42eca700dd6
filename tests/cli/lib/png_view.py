#!/usr/bin/env python3
"""Checks the 3D player's view in headless Chromium screenshots (tests/cli/player.sh).

  png_view.py --moving VIEW A.png B.png --figures VIEW C.png

VIEW is "left,top,width,height" of the player's canvas on the page (CSS
pixels, the page's data-player-view). --moving: the view's pixels differ
between A and B (the figures moved) and each shows figures; --figures: C
shows figures. "Figures" means the synthesised motion's red or the chosen /
first rank's gold, the feet's green, and the grid's grey on the light
background, each over a minimum number of pixels. Python 3 and numpy
(Debian's python3-numpy, installed by scripts/setup).
"""
import argparse
import struct
import sys
import zlib

import numpy as np


def read_png(path, rows_needed=None):
    """RGB array (h, w, 3) of an 8-bit RGB or RGBA PNG without interlace; only
    the first rows_needed rows are decoded (the rest stay 0)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat = 8, b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or ctype not in (2, 6) or interlace:
                raise SystemExit(f"{path}: unsupported PNG (depth {depth}, type {ctype})")
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8)
    stride = w * bpp
    rows = raw.reshape(h, stride + 1)
    out = np.zeros((h, stride), dtype=np.uint8)
    rows_needed = h if rows_needed is None else min(h, rows_needed)
    prev = np.zeros(stride, dtype=np.int32)
    for y in range(h):
        f = rows[y, 0]
        line = rows[y, 1:].astype(np.int32)
        if f == 0:
            cur = line
        elif f == 2:
            cur = (line + prev) & 255
        elif f == 1:
            # Sub: a running sum per channel.
            cur = (np.cumsum(line.reshape(w, bpp), axis=0) & 255).reshape(stride)
        else:  # Average or Paeth: pixel by pixel (Python ints: faster than numpy's)
            cur, up = line.tolist(), prev.tolist()
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b = up[i]
                if f == 3:
                    cur[i] = (cur[i] + (a + b) // 2) & 255
                else:
                    c = up[i - bpp] if i >= bpp else 0
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    cur[i] = (cur[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
            cur = np.array(cur, dtype=np.int32)
        out[y] = cur
        prev = cur
        if y + 1 >= rows_needed:
            break
    return out.reshape(h, w, bpp)[:, :, :3].astype(np.int32)


def view_bottom(view):
    x, y, w, h = (float(v) for v in view.split(","))
    return int(round(y + h))


def crop(img, view):
    x, y, w, h = (int(round(float(v))) for v in view.split(","))
    x0, y0 = max(0, x + 2), max(0, y + 2)
    x1, y1 = min(img.shape[1], x + w - 2), min(img.shape[0], y + h - 2)
    if x1 - x0 < 100 or y1 - y0 < 100:
        raise SystemExit(f"the view {view} is not on the screenshot ({img.shape[1]}x{img.shape[0]})")
    return img[y0:y1, x0:x1]


def check_figures(name, v):
    r, g, b = v[..., 0], v[..., 1], v[..., 2]
    counts = {
        "red (synthesised) or gold (chosen / rank 1)": int(np.sum((r > g + 50) & (r > b + 40))),
        "green (foot in contact)": int(np.sum((g > r + 40) & (g > b + 25))),
        "grey (grid)": int(np.sum((abs(r - g) < 8) & (abs(g - b) < 10) & (r < 200) & (r > 100))),
    }
    background = int(np.sum((abs(r - 0xF4) < 6) & (abs(g - 0xF5) < 6) & (abs(b - 0xF7) < 6)))
    print(f"{name}: view {v.shape[1]}x{v.shape[0]}, background {100 * background / r.size:.0f}%, "
          + ", ".join(f"{k} {n} px" for k, n in counts.items()))
    ok = background > 0.3 * r.size
    for k, n in counts.items():
        if n < 40:
            print(f"{name}: too few {k} pixels ({n})", file=sys.stderr)
            ok = False
    if not ok:
        print(f"{name}: the view does not show the figures on the grid", file=sys.stderr)
    return ok


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--moving", nargs=3, metavar=("VIEW", "A", "B"))
    ap.add_argument("--figures", nargs=2, metavar=("VIEW", "C"), action="append", default=[])
    a = ap.parse_args()
    ok = True
    if a.moving:
        view, pa, pb = a.moving
        va = crop(read_png(pa, view_bottom(view)), view)
        vb = crop(read_png(pb, view_bottom(view)), view)
        ok &= check_figures(pa, va) & check_figures(pb, vb)
        changed = int(np.sum(np.abs(va - vb).max(axis=2) > 24))
        print(f"{pa} -> {pb}: {changed} view pixels changed")
        if changed < 300:
            print("the figures did not move between the two screenshots", file=sys.stderr)
            ok = False
    for view, pc in a.figures:
        ok &= check_figures(pc, crop(read_png(pc, view_bottom(view)), view))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
