#!/usr/bin/env python3
"""Windward/leeward snow-depth figures of the village-snowdrift preset (issue 5, S1 Fig. 6).

Reads the 16-bit grey snow-depth PNGs that `squall simulate --fields PREFIX` writes
(PREFIX_snow_depth_NNNNN.png: 1 mm per unit, row 0 = north edge, one pixel per lattice column)
with nothing but the standard library (zlib + struct), and

  stats   prints the mean depth in bands around the preset's houses and fence (markdown table,
          one column per group of runs: mean over the runs, and their spread);
  image   writes a false-colour top-down depth map (RGB PNG) with the obstacles outlined, an
          optional wind arrow and a labelled colour bar.

The band geometry is the preset's (scenes/village-snowdrift.yaml): a 128 x 64 lattice of 1 m
cells centred on the origin, x east, y north; a cell belongs to an obstacle when its centre lies
inside the footprint, edges included (as the lattice voxelises it). Docs: docs/phen/snowdrift.md,
section "Windward and leeward deposition".

usage:
  snow-depth-figure.py stats [--yaw90] LABEL=A.png[,B.png,...] [LABEL=...]
  snow-depth-figure.py image DEPTH.png OUT.png [--max M] [--scale S] [--smooth R] [--wind]

--yaw90: the houses turned by 90 degrees (yaw_deg: 90; ridges north-south, so the west roof
half is the windward slope); only the band geometry changes.
--smooth R averages each cell with the cells of the same kind (ground, or the same obstacle's
roof) in the (2R+1) x (2R+1) window around it; roofs and ground are never mixed.
"""
import struct
import sys
import zlib

# ---- preset geometry ---------------------------------------------------------------------
CELL = 1.0
HOUSES = [  # name, centre x, y, size x, y (m)
    ("house A (12 x 8 m, west)", -18.0, 2.0, 12.0, 8.0),
    ("house B (10 x 8 m, north-east)", 16.0, 13.0, 10.0, 8.0),
    ("house C (9 x 7 m, south-east)", 20.0, -13.0, 9.0, 7.0),
]
FENCE = (-43.5, 0.0, 1.0, 30.0)  # centre x, y, size x, y (m), 2 m high
BAND = 3.0  # width of the bands at the foot of the walls (m)


def read_png16(path):
    """Grey 16-bit PNG (non-interlaced) -> (width, height, rows of ints, row 0 = top)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, hdr = 8, [], None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + n
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 16 or ctype != 0 or interlace != 0:
        raise ValueError(f"{path}: want 16-bit grey non-interlaced PNG, got depth {depth} "
                         f"colour type {ctype} interlace {interlace}")
    raw = zlib.decompress(b"".join(idat))
    bpp, stride = 2, 2 * w
    prev = bytearray(stride)
    rows = []
    for r in range(h):
        ft = raw[r * (stride + 1)]
        line = bytearray(raw[r * (stride + 1) + 1:(r + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ft == 1:
                line[i] = (line[i] + a) & 255
            elif ft == 2:
                line[i] = (line[i] + b) & 255
            elif ft == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ft == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pr) & 255
            elif ft != 0:
                raise ValueError(f"{path}: bad PNG filter {ft}")
        rows.append([(line[2 * i] << 8) | line[2 * i + 1] for i in range(w)])
        prev = line
    return w, h, rows


def depth_grid(path):
    """Depth in metres as grid[j][i], j = 0 at the south edge (lattice order)."""
    w, h, rows = read_png16(path)
    return w, h, [[v * 0.001 for v in rows[h - 1 - j]] for j in range(h)]


def centre(w, h, i, j):
    return (-0.5 * w * CELL + (i + 0.5) * CELL, -0.5 * h * CELL + (j + 0.5) * CELL)


def bands():
    """(name, predicate(x, y)) for every band of the table."""
    out = []
    for name, cx, cy, sx, sy in HOUSES:
        x0, x1, y0, y1 = cx - sx / 2, cx + sx / 2, cy - sy / 2, cy + sy / 2
        iny = (lambda y0=y0, y1=y1: lambda y: y0 <= y <= y1)()
        short = name.split(" (")[0]
        out += [
            (f"{short}: windward foot (west, 0-{BAND:g} m)",
             lambda x, y, x0=x0, iny=iny: x0 - BAND <= x < x0 and iny(y)),
            (f"{short}: leeward foot (east, 0-{BAND:g} m)",
             lambda x, y, x1=x1, iny=iny: x1 < x <= x1 + BAND and iny(y)),
            (f"{short}: lee 3-10 m",
             lambda x, y, x1=x1, iny=iny: x1 + BAND < x <= x1 + 10 and iny(y)),
            (f"{short}: side foot (north + south, 0-{BAND:g} m)",
             lambda x, y, x0=x0, x1=x1, y0=y0, y1=y1:
             x0 <= x <= x1 and (y1 < y <= y1 + BAND or y0 - BAND <= y < y0)),
            (f"{short}: windward corners (3 x 3 m, NW + SW)",
             lambda x, y, x0=x0, y0=y0, y1=y1:
             x0 - BAND <= x < x0 and (y1 < y <= y1 + BAND or y0 - BAND <= y < y0)),
            (f"{short}: leeward corners (3 x 3 m, NE + SE)",
             lambda x, y, x1=x1, y0=y0, y1=y1:
             x1 < x <= x1 + BAND and (y1 < y <= y1 + BAND or y0 - BAND <= y < y0)),
            (f"{short}: roof, west half",
             lambda x, y, x0=x0, cx=cx, iny=iny: x0 <= x < cx and iny(y)),
            (f"{short}: roof, east half",
             lambda x, y, x1=x1, cx=cx, iny=iny: cx < x <= x1 and iny(y)),
        ]
    fx, fy, fsx, fsy = FENCE
    fx0, fx1, fy0, fy1 = fx - fsx / 2, fx + fsx / 2, fy - fsy / 2, fy + fsy / 2
    out += [
        ("fence: windward (west, 0-5 m)",
         lambda x, y: fx0 - 5 <= x < fx0 and fy0 <= y <= fy1),
        ("fence: leeward (east, 0-5 m)",
         lambda x, y: fx1 < x <= fx1 + 5 and fy0 <= y <= fy1),
        ("fence: lee 5-15 m",
         lambda x, y: fx1 + 5 < x <= fx1 + 15 and fy0 <= y <= fy1),
        ("open ground (y <= -24 m or y >= 24 m)", lambda x, y: abs(y) >= 24),
        ("whole map", lambda x, y: True),
    ]
    return out


def band_means(path):
    w, h, g = depth_grid(path)
    res = []
    for name, pred in bands():
        s, n = 0.0, 0
        for j in range(h):
            for i in range(w):
                x, y = centre(w, h, i, j)
                if pred(x, y):
                    s += g[j][i]
                    n += 1
        res.append((name, s / n if n else float("nan"), n))
    return res


def cmd_stats(args):
    global HOUSES
    if args and args[0] == "--yaw90":
        HOUSES = [(n, cx, cy, sy, sx) for n, cx, cy, sx, sy in HOUSES]
        args = args[1:]
    groups = []
    for a in args:
        label, _, files = a.partition("=")
        groups.append((label, [band_means(p) for p in files.split(",")]))
    names = [(b[0], b[2]) for b in groups[0][1][0]]
    head = "| band | cells | " + " | ".join(f"{g[0]} (m)" for g in groups) + " |"
    print(head)
    print("|---|---:|" + "---:|" * len(groups))
    for k, (name, n) in enumerate(names):
        cells = []
        for _, runs in groups:
            v = [r[k][1] for r in runs]
            m = sum(v) / len(v)
            cells.append(f"{m:.3f}" + (f" ({min(v):.3f}-{max(v):.3f})" if len(v) > 1 else ""))
        print(f"| {name} | {n} | " + " | ".join(cells) + " |")


# ---- false-colour image ------------------------------------------------------------------
# Sequential colour map (depth 0 -> 1): dark blue, blue, cyan, pale yellow, orange, dark red.
CMAP = [(0.0, (20, 24, 82)), (0.2, (33, 102, 172)), (0.4, (67, 190, 210)),
        (0.6, (250, 245, 180)), (0.8, (245, 150, 50)), (1.0, (150, 20, 20))]

FONT = {  # 3 x 5 glyphs, rows top to bottom
    "0": ["111", "101", "101", "101", "111"], "1": ["010", "110", "010", "010", "111"],
    "2": ["111", "001", "111", "100", "111"], "3": ["111", "001", "111", "001", "111"],
    "4": ["101", "101", "111", "001", "001"], "5": ["111", "100", "111", "001", "111"],
    "6": ["111", "100", "111", "101", "111"], "7": ["111", "001", "010", "010", "010"],
    "8": ["111", "101", "111", "101", "111"], "9": ["111", "101", "111", "001", "111"],
    ".": ["000", "000", "000", "000", "010"], "m": ["000", "000", "111", "111", "101"],
    ">": ["100", "010", "001", "010", "100"], " ": ["000", "000", "000", "000", "000"],
}


def cmap(t):
    t = 0.0 if t < 0 else 1.0 if t > 1 else t
    for (t0, c0), (t1, c1) in zip(CMAP, CMAP[1:]):
        if t <= t1:
            f = (t - t0) / (t1 - t0)
            return tuple(int(round(a + (b - a) * f)) for a, b in zip(c0, c1))
    return CMAP[-1][1]


def write_png_rgb(path, w, h, px):
    raw = b"".join(b"\x00" + bytes(px[r]) for r in range(h))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def obstacle_index(w, h, i, j):
    """Which obstacle's footprint holds the cell centre (1 + index; 0 = ground)."""
    x, y = centre(w, h, i, j)
    for k, (_, cx, cy, sx, sy) in enumerate(HOUSES + [("fence",) + FENCE]):
        if abs(x - cx) <= sx / 2 and abs(y - cy) <= sy / 2:
            return k + 1
    return 0


def smooth(w, h, g, r):
    kind = [[obstacle_index(w, h, i, j) for i in range(w)] for j in range(h)]
    out = [[0.0] * w for _ in range(h)]
    for j in range(h):
        for i in range(w):
            s, n = 0.0, 0
            for jj in range(max(0, j - r), min(h, j + r + 1)):
                for ii in range(max(0, i - r), min(w, i + r + 1)):
                    if kind[jj][ii] == kind[j][i]:
                        s += g[jj][ii]
                        n += 1
            out[j][i] = s / n
    return out


def cmd_image(args):
    src, out = args[0], args[1]
    vmax, s, wind, rs = 2.0, 5, False, 0
    k = 2
    while k < len(args):
        if args[k] == "--max":
            vmax, k = float(args[k + 1]), k + 2
        elif args[k] == "--scale":
            s, k = int(args[k + 1]), k + 2
        elif args[k] == "--smooth":
            rs, k = int(args[k + 1]), k + 2
        elif args[k] == "--wind":
            wind, k = True, k + 1
        else:
            sys.exit(f"unknown option {args[k]}")
    w, h, g = depth_grid(src)
    if rs > 0:
        g = smooth(w, h, g, rs)
    bar_h = 44
    W, H = w * s, h * s + bar_h
    px = [bytearray(b"\xff" * (3 * W)) for _ in range(H)]

    def put(x, y, c):
        if 0 <= x < W and 0 <= y < H:
            px[y][3 * x:3 * x + 3] = bytes(c)

    for j in range(h):
        for i in range(w):
            c = cmap(g[j][i] / vmax)
            for yy in range((h - 1 - j) * s, (h - j) * s):
                for xx in range(i * s, (i + 1) * s):
                    put(xx, yy, c)

    def to_px(x, y):  # metres -> image pixel (edge of the cell grid)
        return (int(round((x + 0.5 * w * CELL) / CELL * s)),
                int(round((0.5 * h * CELL - y) / CELL * s)))

    def rect(cx, cy, sx, sy, c):
        # outline the cells whose centres the footprint holds (edges included)
        i0 = min(i for i in range(w) if centre(w, h, i, 0)[0] >= cx - sx / 2)
        i1 = max(i for i in range(w) if centre(w, h, i, 0)[0] <= cx + sx / 2)
        j0 = min(j for j in range(h) if centre(w, h, 0, j)[1] >= cy - sy / 2)
        j1 = max(j for j in range(h) if centre(w, h, 0, j)[1] <= cy + sy / 2)
        xa, xb = i0 * s, (i1 + 1) * s - 1
        ya, yb = (h - 1 - j1) * s, (h - j0) * s - 1
        for t in range(2):
            for x in range(xa, xb + 1):
                put(x, ya + t, c)
                put(x, yb - t, c)
            for y in range(ya, yb + 1):
                put(xa + t, y, c)
                put(xb - t, y, c)

    for _, cx, cy, sx, sy in HOUSES:
        rect(cx, cy, sx, sy, (0, 0, 0))
    rect(*FENCE, (0, 0, 0))

    def text(x, y, txt, scale=2, c=(0, 0, 0)):
        for ch in txt:
            for r, row in enumerate(FONT[ch]):
                for q, bit in enumerate(row):
                    if bit == "1":
                        for dy in range(scale):
                            for dx in range(scale):
                                put(x + q * scale + dx, y + r * scale + dy, c)
            x += 4 * scale

    if wind:  # white arrow toward the east in the north-west corner
        ax, ay, L = 8, 12, 60
        for t in range(-1, 2):
            for x in range(ax, ax + L):
                put(x, ay + t, (255, 255, 255))
        for d in range(10):
            for t in range(-d, d + 1):
                put(ax + L + 9 - d, ay + t, (255, 255, 255))

    # colour bar with ticks every 0.5 m
    y0, bw = h * s + 6, W - 80
    for x in range(bw):
        c = cmap(x / (bw - 1))
        for y in range(y0, y0 + 14):
            put(40 + x, y, c)
    t = 0.0
    while t <= vmax + 1e-9:
        x = 40 + int(round(t / vmax * (bw - 1)))
        for y in range(y0 + 14, y0 + 19):
            put(x, y, (0, 0, 0))
        lab = f"{t:g}" if t < vmax else f">{t:g}"
        text(x - 4 * len(lab) + 2 if t >= vmax else x - 3, y0 + 22, lab)
        t += 0.5
    text(W - 30, y0 + 22, "m")
    write_png_rgb(out, W, H, px)


def main(argv):
    if len(argv) < 2 or argv[1] not in ("stats", "image"):
        sys.exit(__doc__)
    if argv[1] == "stats":
        cmd_stats(argv[2:])
    else:
        cmd_image(argv[2:])


if __name__ == "__main__":
    main(sys.argv)
