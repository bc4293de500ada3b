/* registry.c — the cases of `squall bench` and `squall validate`. One line per case;
 * implementations live in apps/cli/bench_<family>.c and apps/cli/validate_<family>.c. */
#include "cli.h"
#include "cases.h"

static const char render_volume_details[] =
    "  --width W, --height H  frame size in pixels (default 1280 x 720; 16..16384)\n"
    "  --size N               dust volume of N^3 cells (default 128; 4..1024), fBm noise\n"
    "  --slices K             half-angle slices through the volume (default 128; 1..4096)\n"
    "  --light L              light-buffer texels per side (default 256; 8..4096); the light\n"
    "                         array holds one L^2 RGBA16F layer per slice (128 slices at 256:\n"
    "                         68 MB) and is swept in chunks above 256 MB (or a quarter of\n"
    "                         the context's memory limit, 80 % of RAM by default)\n"
    "  --particles P          soft particles in the particle configuration (default 100000)\n"
    "  --only WHAT            measure one configuration: volume (the dust volume alone),\n"
    "                         particles (the soft particles alone) or base (sky and terrain\n"
    "                         only: the base renderer's share); default: all three, one JSON\n"
    "                         line each\n"
    "Each frame is draw + 8-bit read-back (which waits for the GL work). The JSON carries the\n"
    "GL renderer string: figures from llvmpipe (CPU) and from a GPU are not comparable.\n";

const sq_cli_case sq_cli_bench_cases[] = {
    {"stream", "STREAM triad memory bandwidth only", "", sq_bench_stream_case, NULL, NULL},
    {"render-volume", "GL ms per frame: 128^3 dust volume, 10^5 soft particles, neither",
     "--width 1280 --height 720 --size 128 --slices 128 --light 256 --particles 100000 "
     "--only volume|particles|base",
     sq_bench_render_volume, NULL, render_volume_details},
    {"grid", "MAC-grid fluid step: MacCormack advection + MGPCG projection + 2 scalars",
     "--grid 64|128", sq_bench_grid, NULL, NULL},
    {"lbm", "D3Q15 wind step: fused collide + stream (AA pattern), periodic box (under mpirun: "
            "z slabs, per-rank figures, bytes sent)",
     "--size 128|256x128x128 --collision trt|bgk|smagorinsky", sq_bench_lbm, NULL, NULL},
    {"project", "MAC-grid pressure projection alone (MGPCG to 1e-3, cold start) over a ridge "
                "(under mpirun: slabs, per-rank figures, bytes sent per projection)",
     "--size 128x64x64", sq_bench_project, NULL, NULL},
    {"sandstorm", "full two-phase desert-sandstorm step (wind, projection to 1e-3, 4 dust bins)",
     "--grid 64|128|64x64x32 --world dunes|flat --spinup 10 --detail 0 "
     "--turbulence mixing-length|smagorinsky|tke", sq_bench_sandstorm, NULL, NULL},
    {"sph", "SPH sub-step (sort, density, strain, forces, integrate): Cross snow and water",
     "--particles 65536|262144|1048576 --model cross|water|both", sq_bench_sph, NULL, NULL},
    {"snowdrift", "village-snowdrift frame (1/24 s): D3Q15 wind, u*, snow transport/deposition/"
     "erosion, flakes, drawables; per-stage ms",
     "--preset village-snowdrift --spinup 48", sq_bench_snowdrift, NULL, NULL},
    {"wrf", "WRF reader: open + read and derive every stored time; one time; an interpolated time",
     "--file wrfout.nc (repeatable; default data/wrf sample)", sq_bench_wrf, NULL, NULL},
    {"clouds", "clouds (S4): 15 000 particles lit (MFS) and drawn, plain vs structured; S4 "
     "Table 1 rows; impostors vs particles for a distant field",
     "--particles 15000 --width 640 --height 360 --only frame|table|impostor", sq_bench_clouds,
     NULL, NULL},
    {"snow-cover", "snow-cover preset frame (S2 ch. 2): occlusion map, snow on every surface, "
     "falling flakes; faces, flakes, ms_occlusion_map, ms_scene, ms_flakes, ms_per_frame",
     "--preset snowy-suburb --time 12 --width 640 --height 360", sq_bench_snowcover, NULL, NULL},
    /* helpers: add bench cases here, e.g. {"lbm", "...", "--size 128|256x128x128", sq_bench_lbm, NULL, NULL}, */
    {NULL, NULL, NULL, NULL, NULL, NULL},
};

const sq_cli_case sq_cli_validate_cases[] = {
    {"lbm-cavity", "lid-driven cavity (D3Q15, TRT): centre-line profiles vs Ghia et al. 1982",
     "--re 100|400|1000 --n 64", NULL, sq_validate_lbm_cavity, NULL},
    {"dam-break", "SPH water-column collapse (n^2 = 2): surge front Z(T) vs Martin & Moyce 1952",
     "--particles 25 (across a = 0.05715 m) --gate-speed 0 (m/s; 0 = instantaneous) "
     "--gate-accel 0 (m/s^2: the gate starts from rest; 9.81 = opens in the free-fall time) "
     "--front-depth 0 (m; 0 = the farthest particle, H = the farthest column H deep) "
     "--every 0.005 --t-end (T = 4) --a --spacing --alpha 0.02 --kernel cubic|muller", NULL,
     sq_validate_dam_break, NULL},
    {"lock-exchange", "full-depth lock-exchange gravity current on the sandstorm's grid solver: "
     "front speed and Froude number vs Benjamin 1968 / Shin, Dalziel & Linden 2004 (Fr = 1/2)",
     "--n 32 --depth 1000 --delta-t 3 --closure none|smagorinsky|tke --confinement 0 "
     "--plain-confinement --spanwise 0 --width 4 --json", NULL,
     sq_validate_lock_exchange, NULL},
    /* helpers: add validate cases here, e.g. {"lbm-cavity", "...", "--re 100 --n 64", NULL, sq_validate_lbm_cavity, NULL}, */
    {NULL, NULL, NULL, NULL, NULL, NULL},
};
