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


# ---- the grid solver's pressure projection (MGPCG, slabs; docs/performance.md "MPI: the grid
# solver's projection"). Per CG iteration (one V-cycle, one red-black sweep before and after on
# every level) a rank: works on its slab's fine cells (t_it per cell and iteration), exchanges
# one float plane with each neighbour 6 times (4 smoother half-sweeps, the prolongation, the
# search direction), makes 3 small allreduces (latency x log2 P each), and - as implemented -
# sums the whole level 1 over the ranks (an allreduce of N/8 floats: ~2 x that through each
# rank's link) and cycles the whole coarse hierarchy itself (N/7 cells, not divided).
# The "next step" rows keep the levels distributed (halo exchanges on every level, aligned
# slabs) down to a level of at most 2^21 cells, gathered there (allgather) and solved on every rank.
IT_CELLS = float(sys.argv[2]) if len(sys.argv) > 2 else 1.2e9  # cell-iterations/s of one node
T_IT = 1.0 / IT_CELLS
GG = (2048, 1024, 512)  # a 20 km x 10 km x 5 km haboob at ~10 m: 1.07e9 cells
NG = GG[0] * GG[1] * GG[2]


def project_iteration(p, bw, lat, gathered_at=None):
    import math
    face = (GG[1] + 2) * (GG[2] + 2)  # slabs along x
    comp = NG / p * T_IT
    halo = 6 * (lat + 2 * 4 * face / bw) if p > 1 else 0.0
    red = 3 * lat * math.log2(p) if p > 1 else 0.0
    if gathered_at is None:  # implemented: redundant from level 1
        coarse = NG / 7 * T_IT if p > 1 else NG / 7 * T_IT
        lvl = 2 * (NG / 8) * 4 / bw + 2 * lat * math.log2(p) if p > 1 else 0.0
        sent = 6 * 2 * 4 * face + 2 * (NG / 8) * 4 if p > 1 else 0
    else:  # distributed levels down to `gathered_at` cells, gathered there
        coarse = (NG / 7 / p + gathered_at * 8 / 7) * T_IT
        levels = int(round(math.log(NG / gathered_at, 8)))
        halo_c = sum(5 * (lat + 2 * 4 * face / 4 ** l / bw) for l in range(1, levels))
        lvl = gathered_at * 4 / bw + lat * math.log2(p) if p > 1 else 0.0
        halo += halo_c if p > 1 else 0.0
        sent = 6 * 2 * 4 * face + gathered_at * 4 / p if p > 1 else 0
    return comp, coarse, halo + red + lvl, sent


print(f"\nPressure projection (MGPCG, slabs along x), grid {GG[0]}x{GG[1]}x{GG[2]}, one node "
      f"{IT_CELLS:.3g} cell-iterations/s")
for net, (bw, lat) in NETS.items():
    print(f"\n{net}")
    print("ranks | coarse levels | ms per iteration: fine, coarse, communication | "
          "bytes sent/rank/iteration | efficiency")
    base = sum(project_iteration(1, bw, lat)[:3])
    for p in (1, 4, 16, 64, 256):
        for name, ga in (("whole from level 1 (implemented)", None),
                         ("gathered at 2^21 cells (next step)", 2 ** 21)):
            if p == 1 and ga is not None:
                continue
            comp, coarse, comm, sent = project_iteration(p, bw, lat, ga)
            t = comp + coarse + comm
            print(f"{p} | {name} | {comp * 1e3:.3g}, {coarse * 1e3:.3g}, {comm * 1e3:.3g} | "
                  f"{sent / 1e6:.3g} MB | {base / (p * t):.0%}")

# ---- the sandstorm's whole step (slabs along x; docs/performance.md "MPI: the sandstorm's
# step"). Per step a rank steps its slab (N/P cells at STEP_CELLS cell-steps/s per node), meets
# its neighbours about MEET times (ghost fills, the advection's widened copy, the projection's
# planes and sums) moving H_PLANES float planes of the slab face each way, does the
# projection's coarse levels whole (N/7 cells at the projection's share of the step, not
# divided) with the level-1 sum (N/8 floats per V-cycle, ~4 V-cycles). Once per output frame
# (every FRAME_STEPS steps) the slabs' (4 + bins) fields are gathered to rank 0 (its link
# carries (P-1)/P of N (4 + bins) floats) and the metrics are reduced: the wall seen from ahead
# is a chain of ny nz doubles from the west slab to the east one (P - 1 hops). The first rows
# are the step before this (the whole grid gathered on every rank after every step).
STEP_CELLS = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0e8  # cell-steps/s of one node
H_PLANES = 140   # planes per neighbour and step (measured: bench sandstorm 64^3, 2 ranks)
MEET = 66        # meetings per step (bench sandstorm 64^3, 2 ranks: meetings_per_step; was 114, ~80 est.)
PROJECT_SHARE = 0.12  # the projection's share of one rank's step (bench sandstorm, 64^3)
FIELDS = 8       # 3 wind components, 4 dust bins, theta
FRAME_STEPS = 16


def sandstorm_step(p, bw, lat, gather_every=1, coarse_at=None):
    import math
    face = (GG[1] + 2) * (GG[2] + 2)
    chain = (p - 1) * (lat + GG[1] * GG[2] * 8 / bw) / gather_every if gather_every > 1 else 0.0
    comp = NG / p / STEP_CELLS
    if coarse_at is None:  # implemented: the projection's levels from 1 whole on every rank
        coarse = PROJECT_SHARE * NG / 7 / STEP_CELLS if p > 1 else 0.0
        level1 = 4 * (2 * (NG / 8) * 4 / bw + 2 * lat * math.log2(p)) if p > 1 else 0.0
        lsent = 4 * 2 * (NG / 8) * 4
    else:  # split levels down to coarse_at cells, gathered there
        coarse = PROJECT_SHARE * coarse_at * 8 / 7 / STEP_CELLS if p > 1 else 0.0
        level1 = 4 * (coarse_at * 4 / bw + lat * math.log2(p)) if p > 1 else 0.0
        lsent = 4 * coarse_at * 4 / p
    halo = MEET * lat + H_PLANES * 2 * 4 * face / bw if p > 1 else 0.0
    gather = (NG * FIELDS * 4 * (p - 1) / p / bw + lat * math.log2(p)) / gather_every if p > 1 else 0.0
    sent = (H_PLANES * 2 * 4 * face + lsent +
            NG / p * FIELDS * 4 * ((p - 1) if gather_every == 1 else 1) / gather_every) if p > 1 else 0
    return comp, coarse + halo + level1 + gather + chain, sent


print(f"\nSandstorm step (slabs along x), grid {GG[0]}x{GG[1]}x{GG[2]}, one node "
      f"{STEP_CELLS:.3g} cell-steps/s")
for net, (bw, lat) in NETS.items():
    print(f"\n{net}")
    print("ranks | whole-grid gather, projection coarse levels | compute ms | "
          "communication and coarse ms | bytes sent/rank/step | efficiency")
    for p in (1, 4, 16, 64, 256):
        for name, ge, ca in (("every step on every rank, coarse levels whole (before)", 1, None),
                             (f"rank 0 every {FRAME_STEPS} steps, coarse whole (implemented)",
                              FRAME_STEPS, None),
                             (f"rank 0 every {FRAME_STEPS} steps, coarse gathered at 2^21 (next)",
                              FRAME_STEPS, 2 ** 21)):
            if p == 1 and ge != 1:
                continue
            comp, comm, sent = sandstorm_step(p, bw, lat, ge, ca)
            print(f"{p} | {name} | {comp * 1e3:.4g} | {comm * 1e3:.4g} | {sent / 1e6:.4g} MB | "
                  f"{comp / (comp + comm):.0%}")
    # slab thickness (cells along x) at which the halo alone costs as much as the work
    face = (GG[1] + 2) * (GG[2] + 2)
    t_halo = MEET * lat + H_PLANES * 2 * 4 * face / bw
    n = t_halo * STEP_CELLS / (GG[1] * GG[2])
    print(f"the halo exchange alone equals the work below slabs of about {n:.1f} cells along x "
          f"({GG[0] / max(n, 1e-9):.0f} ranks)")
