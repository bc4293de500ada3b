#!/usr/bin/env python3
"""Communication model of the distributed D3Q15 lattice (docs/performance.md, "MPI").

Per step a rank updates its cells (t_cell each) and exchanges, per split axis, the 5 populations
that cross each of its two faces: 20 bytes per face cell (padded by the ghost cells). The
exchange is not overlapped with the update (as implemented), the two faces of an axis share the
network link, axes are exchanged one after the other:
    T_step = N_block t_cell + sum over split axes of (latency + 2 * 20 * face_cells / bandwidth)
    efficiency = N_block t_cell / T_step
Usage: scripts/mpi-model.py [rank_mlups]   (default 1000: one node streaming 120 GB/s at 120 B
per cell update)."""
import sys

RANK_MLUPS = float(sys.argv[1]) if len(sys.argv) > 1 else 1000.0
T_CELL = 1.0 / (RANK_MLUPS * 1e6)
NETS = {"InfiniBand HDR (25 GB/s, 2 us)": (25e9, 2e-6),
        "25 Gb Ethernet (3 GB/s, 15 us)": (3e9, 15e-6)}
G = (1024, 1024, 1024)  # a 1.07e9-cell lattice (town snowdrift at 0.25 m, haboob at 20 m)


def blocks(p, axes):
    """Least-surface block grid over the allowed axes (as sq_par_decompose)."""
    best = None
    for gz in range(1, p + 1):
        if p % gz:
            continue
        for gy in range(1, p // gz + 1):
            if (p // gz) % gy:
                continue
            g = (p // gz // gy, gy, gz)
            if any(g[a] > 1 and a not in axes for a in range(3)):
                continue
            if any(G[a] // g[a] < 2 for a in range(3)):
                continue
            b = [G[a] / g[a] for a in range(3)]
            surf = sum(2 * b[(a + 1) % 3] * b[(a + 2) % 3] for a in range(3) if g[a] > 1)
            if best is None or surf < best[0]:
                best = (surf, g, b)
    return best


def step(p, axes, bw, lat):
    found = blocks(p, axes)
    if not found:
        return None
    _, g, b = found
    comp = b[0] * b[1] * b[2] * T_CELL
    comm = 0.0
    face_bytes = 0.0
    for a in range(3):
        if g[a] > 1:
            cells = (b[(a + 1) % 3] + 2) * (b[(a + 2) % 3] + 2)
            comm += lat + 2 * 20 * cells / bw
            face_bytes += 2 * 20 * cells
    return comp, comm, face_bytes, g


print(f"rank throughput {RANK_MLUPS:g} MLUPS, lattice {G[0]}x{G[1]}x{G[2]}")
for net, (bw, lat) in NETS.items():
    print(f"\n{net}")
    print("ranks | split | block grid | bytes sent/rank/step | compute ms | exchange ms | efficiency")
    for p in (1, 64, 256, 512, 1024):
        for name, axes in (("z slabs", (2,)), ("3D blocks", (0, 1, 2))):
            r = step(p, axes, bw, lat)
            if r is None:
                print(f"{p} | {name} | impossible (fewer than 2 planes per slab) | | | |")
                continue
            comp, comm, fb, g = r
            print(f"{p} | {name} | {g[0]}x{g[1]}x{g[2]} | {fb / 1e6:.3g} MB | {comp * 1e3:.3g} "
                  f"| {comm * 1e3:.3g} | {comp / (comp + comm):.0%}")
    # block edge n (cubic blocks, 3 split axes) where exchange time equals compute time
    n = 2.0
    while n < 4096:
        comp = n ** 3 * T_CELL
        comm = 3 * (lat + 2 * 20 * (n + 2) ** 2 / bw)
        if comp >= comm:
            break
        n += 1
    print(f"communication dominates below cubic blocks of about {n:.0f}^3 = {n ** 3:.3g} cells")
