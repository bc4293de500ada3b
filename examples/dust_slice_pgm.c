/* dust_slice_pgm.c — read a sandstorm's dust field through the public API and write one
 * horizontal slice of it as a grey PGM image.
 *
 * Shows the typed field reads of squall/phenomenon.h: a named 3D field comes back as a borrowed
 * view (sq_named_field) with its units, the centre of cell (0,0,0) and the cell spacing in
 * metres, x fastest. The view stays valid until the next step of the phenomenon.
 *
 * Run: ./dust_slice_pgm OUT.pgm [level]      (level: cell row above the ground, default 1)
 * The image: x east to the right, y north up; black = no dust, white = the slice's maximum. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <squall/squall.h>

static int fail(const char *what)
{
    fprintf(stderr, "dust_slice_pgm: %s: %s\n", what, sq_last_error());
    return 1;
}

/* Writes width x height 8-bit grey pixels (top row first) to path through a temporary file,
 * so that a failed run never leaves half an image. */
static int write_pgm(const char *path, const unsigned char *pix, int width, int height)
{
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) return -1;
    fprintf(f, "P5\n%d %d\n255\n", width, height);
    size_t n = fwrite(pix, 1, (size_t)width * height, f);
    if (fclose(f) != 0 || n != (size_t)width * height || rename(tmp, path) != 0) {
        remove(tmp);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: dust_slice_pgm OUT.pgm [level]\n");
        return 2;
    }
    const int level = argc > 2 ? atoi(argv[2]) : 1;

    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_WARN;
    sq_context *ctx = NULL;
    if (sq_context_create(&cd, &ctx) != SQ_OK) return fail("context");
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_DUNES; /* dunes: the wind and dust follow the relief */
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 2000.0f;
    wd.terrain.relief_m = 15.0f;
    sq_world *world = NULL;
    if (sq_world_create(ctx, &wd, &world) != SQ_OK) return fail("world");

    const char *settings[] = {"domain.nx=32", "domain.ny=32", "domain.nz=12",
                              "domain.cell_size_m=50", "dust.bins=2", "dust.inflow_kg_m3=0.003"};
    sq_phenomenon_desc pd = {0};
    pd.type = "sandstorm";
    pd.settings = settings;
    pd.setting_count = (int)(sizeof settings / sizeof settings[0]);
    sq_phenomenon *storm = NULL;
    if (sq_phenomenon_create(ctx, &pd, world, &storm) != SQ_OK) return fail("sandstorm");
    if (sq_phenomenon_step(storm, 90.0) != SQ_OK) return fail("step");

    /* The field by name; sq_phenomenon_field(storm, i, &f) lists them all. */
    sq_named_field f;
    if (sq_phenomenon_field_find(storm, "dust_mass_concentration", &f) != SQ_OK)
        return fail("field");
    if (level < 0 || level >= f.nz) {
        fprintf(stderr, "dust_slice_pgm: level = %d: must be in [0, %d)\n", level, f.nz);
        return 2;
    }
    printf("%s (%s): %d x %d x %d cells of %.0f x %.0f x %.0f m, cell (0,0,0) at "
           "(%.0f, %.0f, %.0f) m\n", f.name, f.units, f.nx, f.ny, f.nz, f.spacing_m.x,
           f.spacing_m.y, f.spacing_m.z, f.origin_m.x, f.origin_m.y, f.origin_m.z + 0.0f);

    /* Slice k = level: cell (i, j, k) is data[i + nx * (j + ny * k)]; invalid marks cells
     * inside the ground (no value). */
    const float *slice = f.data + (size_t)level * f.nx * f.ny;
    const unsigned char *invalid = f.invalid ? f.invalid + (size_t)level * f.nx * f.ny : NULL;
    float vmax = 0.0f;
    for (int c = 0; c < f.nx * f.ny; c++)
        if ((!invalid || !invalid[c]) && slice[c] > vmax) vmax = slice[c];
    unsigned char *pix = (unsigned char *)calloc((size_t)f.nx * f.ny, 1);
    if (!pix) return 1;
    for (int j = 0; j < f.ny; j++)
        for (int i = 0; i < f.nx; i++) {
            const int c = i + f.nx * j;
            const float v = (invalid && invalid[c]) || vmax <= 0.0f ? 0.0f : slice[c] / vmax;
            pix[i + f.nx * (f.ny - 1 - j)] = (unsigned char)(255.0f * v + 0.5f); /* north up */
        }
    printf("slice z = %.0f m: max %.3g %s -> %s\n", f.origin_m.z + level * f.spacing_m.z, vmax,
           f.units, argv[1]);
    const int rc = write_pgm(argv[1], pix, f.nx, f.ny);
    if (rc != 0) fprintf(stderr, "dust_slice_pgm: %s: cannot write\n", argv[1]);

    free(pix);
    sq_phenomenon_destroy(storm);
    sq_world_destroy(ctx, world);
    sq_context_destroy(ctx);
    return rc == 0 ? 0 : 1;
}
