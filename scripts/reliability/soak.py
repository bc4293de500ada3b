#!/usr/bin/python3
"""soak.py SQUALL [CASE...] — long runs of every phenomenon: the budget stays closed and the
memory stays flat (issue 17, part 8). Results go to docs/reliability.md by hand.

Each case runs `squall simulate` for at least 10 000 solver steps on a small scene, with its
metrics, while the resident set size (VmRSS, /proc/PID/status) is sampled every 0.2 s. Reported
per case, as one JSON line:
  steps       solver steps (frames x steps per frame; the avalanche counts its sub-steps)
  budget      the worst closure error over all frames, relative to the quantity's size:
              sandstorm  |suspended - (inflow + emitted - deposited - outflow)| / emitted+inflow
              snowdrift  |fallen - (airborne + deposited + left)| / fallen
              avalanche  |mass_balance| = |particles + removed - released| / released (SPH
                         mass: particles are never created or lost)
              clouds     |particles - particles at frame 1| / particles (structured particles
                         are recycled, never leaked)
              snowcover  the worse of |water lying - rate x t x speedup| / (rate x t x speedup)
                         (open flat ground) and |flakes - flakes at frame 1| / flakes
  rss_mb      RSS at 10, 25, 50, 75 and 100 % of the run; growth_mb = end - 50 % value (the
              first half includes the warm-up: pages first touched as dust, snow or particles
              spread, and buffers that grow to the scene's steady size)
A case fails (exit 1) when the budget error exceeds 1e-3 or the RSS grows by more than
max(4 MiB, 2 %) over the second half of the run.

  scripts/reliability/soak.py build/release/squall             # all cases
  scripts/reliability/soak.py build/release/squall snowdrift   # one
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.dirname(os.path.dirname(HERE))

SNOW_YAML = """seed: 3
world:
  terrain: {kind: flat, material: snow, size_m: [200, 200], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
layers:
  - type: snowdrift
    name: snow
    domain: {nx: 32, ny: 24, nz: 16, cell_size_m: 2}
    wind: {speed_mps: 6, beaufort: 3}
    snow: {snowfall_mmh: 4, speedup: 2000}
    draw: {flakes: 200}
output: {fps: 24}
"""

SNOWCOVER_YAML = """seed: 3
world:
  terrain: {kind: flat, size_m: [200, 200], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
layers:
  - type: snowcover
    name: cover
    snowfall: {rate_mmh: 2, speedup: 100}
    flakes: {count: 2000}
output: {fps: 24}
"""
SNOWCOVER_RATE_MMH, SNOWCOVER_SPEEDUP = 2.0, 100.0

# name: (scene arguments, frames, solver steps per frame or the metric that counts them)
CASES = {
    "sandstorm": (["haboob", "--set", "layers.storm.domain.nx=24", "--set",
                   "layers.storm.domain.ny=12", "--set", "layers.storm.domain.nz=10", "--set",
                   "layers.storm.coldpool.depth_m=300", "--set",
                   "layers.storm.coldpool.length_m=300", "--set",
                   "layers.storm.near.particles=200", "--set",
                   "world.terrain.resolution=[33, 33]"], 10000, 1),
    "snowdrift": (["@snow.yaml"], 1820, 5.5),
    "avalanche": ([os.path.join(SRC, "tests/cli/data/slope-avalanche.yaml"), "--set",
                   "layers.slide.particles.spacing_m=1.5"], 2000, "slide.substeps"),
    "clouds": (["wrf-clouds", "--set", "layers.clouds.particles.count=2000"], 10000, 1),
    "snowcover": (["@snowcover.yaml"], 10000, 1),
}


def column(rows, prefix):
    for k in rows[0]:
        if k.split(" ")[0] == prefix:
            return [float(r[k]) for r in rows]
    raise SystemExit("no metric %s (columns: %s)" % (prefix, ", ".join(rows[0])))


def budget(name, rows):
    if name == "sandstorm":
        s, e, d, o, i = (column(rows, "storm." + c) for c in (
            "dust_suspended_kg", "dust_emitted_kg", "dust_deposited_kg", "dust_outflow_kg",
            "dust_inflow_kg"))
        return max(abs(s[k] - (i[k] + e[k] - d[k] - o[k])) / max(e[k] + i[k], 1e-9)
                   for k in range(len(rows)) if e[k] + i[k] > 0)
    if name == "snowdrift":
        f, a, d, l = (column(rows, "snow." + c) for c in (
            "snow_fallen_kg", "snow_airborne_kg", "snow_deposited_kg", "snow_left_kg"))
        return max(abs(f[k] - (a[k] + d[k] + l[k])) / f[k] for k in range(len(rows)) if f[k] > 0)
    if name == "avalanche":
        return max(abs(m) for m in column(rows, "slide.mass_balance"))
    if name == "snowcover":
        t, w, fl = (column(rows, c) for c in ("time_s", "cover.snow_water_mm", "cover.flakes"))
        exact = [SNOWCOVER_RATE_MMH * SNOWCOVER_SPEEDUP * x / 3600.0 for x in t]
        water = max(abs(w[k] - exact[k]) / exact[k] for k in range(len(rows)) if exact[k] > 0)
        return max(water, max(abs(x - fl[0]) / fl[0] for x in fl))
    p = column(rows, "clouds.particles")
    return max(abs(x - p[0]) / p[0] for x in p)


def rss_kb(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def run(squall, name, work):
    args, frames, per_frame = CASES[name]
    args = [os.path.join(work, a[1:]) if a.startswith("@") else a for a in args]
    metrics = os.path.join(work, name + ".csv")
    cmd = [squall, "simulate"] + args + ["--frames", str(frames), "--metrics", metrics,
                                         "--overwrite", "--quiet", "--threads", "1"]
    t0 = time.time()
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    samples = []
    while p.poll() is None:
        kb = rss_kb(p.pid)
        if kb:
            samples.append((time.time() - t0, kb))
        time.sleep(0.2)
    err = p.stderr.read()
    if p.returncode != 0:
        return {"case": name, "ok": False, "error": err.strip()}
    with open(metrics) as f:
        rows = list(csv.DictReader(f))
    if isinstance(per_frame, str):
        steps = int(sum(column(rows, per_frame)))
    else:
        steps = int(frames * per_frame)
    wall = time.time() - t0
    def at(frac):
        kb = [k for t, k in samples if t >= frac * wall] or [samples[-1][1]]
        return round(kb[0] / 1024.0, 1)

    quart = [at(f) for f in (0.1, 0.25, 0.5, 0.75)] + [round(samples[-1][1] / 1024.0, 1)]
    growth = quart[4] - quart[2]
    err_b = budget(name, rows)
    ok = err_b <= 1e-3 and growth <= max(4.0, 0.02 * quart[2]) and steps >= 10000
    return {"case": name, "ok": ok, "frames": len(rows), "steps": steps, "budget": err_b,
            "rss_mb": quart, "growth_mb": round(growth, 2), "wall_s": round(wall, 1)}


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    squall = os.path.abspath(sys.argv[1])
    names = sys.argv[2:] or list(CASES)
    failed = 0
    with tempfile.TemporaryDirectory(prefix="squall-soak-") as work:
        with open(os.path.join(work, "snow.yaml"), "w") as f:
            f.write(SNOW_YAML)
        with open(os.path.join(work, "snowcover.yaml"), "w") as f:
            f.write(SNOWCOVER_YAML)
        for name in names:
            r = run(squall, name, work)
            print(json.dumps(r), flush=True)
            failed += not r["ok"]
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
