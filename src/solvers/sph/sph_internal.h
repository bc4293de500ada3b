/* sph_internal.h — the SPH solver's state (structure of arrays), the kernel functions
 * (SPEC §7.3, written in the normalised distance q = r/H so that small supports do not
 * underflow in float) and the prototypes of the passes. See include/squall/sph.h. */
#ifndef SQ_SPH_INTERNAL_H
#define SQ_SPH_INTERNAL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/sph.h"

#define SQ__SPH_PI_F 3.14159265358979323846f
#define SQ__SPH_IMAGE_SHIFT 29u                  /* list entry = j | mask << 29 */
#define SQ__SPH_INDEX_MASK ((1u << 29) - 1u)
#define SQ__SPH_MAX_PARTICLES ((size_t)1 << 29)   /* indices must fit the list entries */
#define SQ__SPH_DET_MIN 0.05f                    /* below: no gradient correction (L = I) */
#define SQ__SPH_TRACE_MAX 12.0f                  /* above tr(L): no gradient correction */
#define SQ__SPH_RUNAWAY_MACH 3.0                  /* |v| > 3 c_s counts as a blow-up */

/* ---- kernels ------------------------------------------------------------------------------ */
typedef enum sq__sph_kernel_fn {
    SQ__SPH_W_POLY6 = 0,
    SQ__SPH_W_SPIKY = 1,
    SQ__SPH_W_VISC = 2,
    SQ__SPH_W_CUBIC = 3
} sq__sph_kernel_fn;

/* Constants of the kernels for one support radius H (all precomputed once). */
typedef struct sq__sph_kern {
    int cubic;          /* 1: cubic spline everywhere (SQ_SPH_KERNEL_CUBIC) */
    float H, H2, inv_H, inv_H2;
    float poly6_c;      /* 315 / (64 π H³) */
    float spiky_w_c;    /* 15 / (π H³) */
    float spiky_g_c;    /* 45 / (π H⁴) */
    float visc_w_c;     /* 15 / (2 π H³) */
    float visc_lap_c;   /* 45 / (π H⁵) */
    float cubic_c;      /* σ = 1/(π ℓ³) = 8/(π H³), ℓ = H/2 */
    float cubic_g_c;    /* σ/ℓ */
    float ell, ell2;    /* ℓ = H/2 */
} sq__sph_kern;

void sq__sph_kern_init(sq__sph_kern *k, float H, int cubic);

/* The kernels are forced inline: they sit inside the vectorised neighbour loops. */
#if defined(__GNUC__)
#define SQ__SPH_KERNEL_FN static inline __attribute__((always_inline))
#else
#define SQ__SPH_KERNEL_FN static inline
#endif

/* max without libm's NaN rules (compiles to maxss); NaN in a gives b. */
SQ__SPH_KERNEL_FN float sq__maxf(float a, float b) { return a > b ? a : b; }

/* sqrt of a number the compiler can see is ≥ 0 (and not NaN): no errno path, so loops that
 * use it vectorise without -fno-math-errno. */
SQ__SPH_KERNEL_FN float sq__sph_sqrt(float x) { return sqrtf(x > 0.0f ? x : 0.0f); }

/* Poly6 W from r²: 315/(64 π H³) (1 − q²)³, zero for r ≥ H. */
SQ__SPH_KERNEL_FN float sq__sph_w_poly6(const sq__sph_kern *k, float r2)
{
    float w = 1.0f - r2 * k->inv_H2;
    w = w > 0.0f ? w : 0.0f;
    return k->poly6_c * w * w * w;
}
/* Spiky W: 15/(π H³) (1 − q)³. */
SQ__SPH_KERNEL_FN float sq__sph_w_spiky(const sq__sph_kern *k, float r)
{
    float w = 1.0f - r * k->inv_H;
    w = w > 0.0f ? w : 0.0f;
    return k->spiky_w_c * w * w * w;
}
/* Müller's viscosity kernel: 15/(2π H³) (−q³/2 + q² + 1/(2q) − 1) (singular at r = 0). */
SQ__SPH_KERNEL_FN float sq__sph_w_visc(const sq__sph_kern *k, float r)
{
    float q = r * k->inv_H;
    if (q >= 1.0f) return 0.0f;
    if (q < 1e-6f) q = 1e-6f;
    return k->visc_w_c * (-0.5f * q * q * q + q * q + 0.5f / q - 1.0f);
}
/* Laplacian of the viscosity kernel: 45/(π H⁶) (H − r) = 45/(π H⁵) (1 − q). */
SQ__SPH_KERNEL_FN float sq__sph_lap_visc(const sq__sph_kern *k, float r)
{
    float w = 1.0f - r * k->inv_H;
    return w > 0.0f ? k->visc_lap_c * w : 0.0f;
}
/* Cubic spline with ℓ = H/2 (support H), s = r/ℓ. */
SQ__SPH_KERNEL_FN float sq__sph_w_cubic(const sq__sph_kern *k, float r)
{
    float s = 2.0f * r * k->inv_H;
    if (s < 1.0f) return k->cubic_c * (1.0f - 1.5f * s * s + 0.75f * s * s * s);
    if (s < 2.0f) {
        float t = 2.0f - s;
        return k->cubic_c * 0.25f * t * t * t;
    }
    return 0.0f;
}
/* The density/XSPH kernel of the kernel set. */
SQ__SPH_KERNEL_FN float sq__sph_w(const sq__sph_kern *k, float r2)
{
    return k->cubic ? sq__sph_w_cubic(k, sq__sph_sqrt(r2)) : sq__sph_w_poly6(k, r2);
}
/* Gradient factor f of the gradient kernel: ∇_i W(x_i − x_j) = f · (x_i − x_j), from r and
 * 1/r (inv_r = 0 at r = 0 gives f = 0). Spiky: f = −45/(π H⁴) (1 − q)²/r; cubic: (dW/dr)/r.
 * Branch-free; cubic is a compile-time constant in the passes. */
SQ__SPH_KERNEL_FN float sq__sph_gradf_rk(const sq__sph_kern *k, float r, float inv_r, int cubic)
{
    if (cubic) {
        const float s = 2.0f * r * k->inv_H;
        const float t = sq__maxf(2.0f - s, 0.0f);
        const float inner = -3.0f * s + 2.25f * s * s;
        const float outer = -0.75f * t * t;
        return k->cubic_g_c * (s < 1.0f ? inner : outer) * inv_r;
    }
    const float w = sq__maxf(1.0f - r * k->inv_H, 0.0f);
    return -k->spiky_g_c * w * w * inv_r;
}
SQ__SPH_KERNEL_FN float sq__sph_gradf_r(const sq__sph_kern *k, float r, float inv_r)
{
    return k->cubic ? sq__sph_gradf_rk(k, r, inv_r, 1) : sq__sph_gradf_rk(k, r, inv_r, 0);
}
SQ__SPH_KERNEL_FN float sq__sph_gradf(const sq__sph_kern *k, float r)
{
    return sq__sph_gradf_r(k, r, r > 0.0f ? 1.0f / r : 0.0f);
}
/* Gradient factor of the poly6 kernel: ∇W = −945/(32 π H⁹) (H² − r²)² r (SPEC eq. 3.16). */
SQ__SPH_KERNEL_FN float sq__sph_gradf_poly6(const sq__sph_kern *k, float r2)
{
    float w = 1.0f - r2 * k->inv_H2;
    if (w <= 0.0f) return 0.0f;
    return -6.0f * k->poly6_c * k->inv_H2 * w * w;
}
/* Generic evaluation for tests: W and ∇W (vector) of kernel fn at displacement d. */
float sq__sph_kernel_w(const sq__sph_kern *k, sq__sph_kernel_fn fn, float r);
void sq__sph_kernel_grad(const sq__sph_kern *k, sq__sph_kernel_fn fn, const float d[3],
                         float g[3]);

/* ---- rheology --------------------------------------------------------------------------- */
typedef struct sq__sph_rheo {
    int kind;                 /* sq_sph_rheology_kind, resolved (never DEFAULT) */
    float mu, k, n, mu0, mu_inf, tau_y, m, gmin, mu_cap;
} sq__sph_rheo;

void sq__sph_rheo_init(sq__sph_rheo *r, const sq_sph_rheology *in);
/* Effective viscosity μ(|γ̇|) in Pa·s. */
float sq__sph_rheo_mu(const sq__sph_rheo *r, float gamma_dot);
sq_sph_rheology sq__sph_rheology_resolve(const sq_sph_rheology *in);

/* ---- colliders ---------------------------------------------------------------------------- */
typedef struct sq__sph_contact {
    float e, mu_k;
    int column;               /* column friction (terrain only): mu_k and turb_k act on the flow
                                 column in sph.c (basal_drag); the contact is frictionless */
    float col_mu;             /* column friction: μ_k */
    float turb_k;             /* column friction: Voellmy g / ξ (1), 0 = none */
} sq__sph_contact;

typedef struct sq__sph_terrain {
    int nx, ny;
    float ox, oy, dx, dy, inv_dx, inv_dy;
    float *h;                 /* owned copy, nx*ny */
    sq__sph_contact c;
} sq__sph_terrain;

typedef struct sq__sph_box {
    float lo[3], hi[3];
    sq__sph_contact c;
} sq__sph_box;

/* A voxelised solid: signed distance (m) at the cell centres, (i, j, k) at
 * o + (i + 1/2, j + 1/2, k + 1/2) h, stored at i + nx (j + ny k). */
typedef struct sq__sph_sdf {
    int nx, ny, nz;
    float o[3], h, inv_h;
    float lo[3], hi[3];       /* the box of the centres */
    float *d;                 /* owned */
    sq__sph_contact c;
} sq__sph_sdf;

void sq__sph_terrain_eval(const sq__sph_terrain *t, float x, float y, float *h, float n[3]);
/* Checks a collider's contact description (restitution, friction) naming `what`. */
sq_result sq__sph_contact_from_desc(sq_sph *s, const sq_sph_collider_desc *c, const char *what,
                                    sq__sph_contact *out);
/* Trilinear signed distance at p and its gradient (normalised; zero where flat); false outside
 * the box of the centres. */
bool sq__sph_sdf_eval(const sq__sph_sdf *g, const float p[3], float *d, float n[3]);

/* ---- the solver ------------------------------------------------------------------------ */
struct sq_sph {
    sq_context *ctx;
    sq_sph_desc d;            /* resolved */
    int nt;                   /* threads */
    int avx512;               /* the passes run the AVX-512 loops (sq__sph_uses_avx512) */

    /* constants (internal units = SI, float) */
    sq__sph_kern k;
    sq__sph_rheo rheo;
    int newtonian;            /* NEWTONIAN rheology: μ constant */
    int visc;                 /* sq_sph_viscous, resolved */
    int corrected;            /* gradient correction on */
    int tait;
    int tensile;
    float mass, rho0, c0, c2, tait_b, tait_gamma, inv_tait_gamma, xsph_eps;
    float av_c;               /* α c_s ℓ (artificial viscosity), 0 = off */
    float p_bg;               /* background pressure */
    /* Pressure-gradient scale: 1 / (the renormalisation a cubic lattice of the spacing needs,
     * Σ_j V (z_j − z_i) ∂W/∂z_i) with CORRECTED gradients, else 1. A constant factor keeps the
     * pressure force the gradient of an energy (a position-dependent L would not, and pumps
     * energy into free surfaces); the viscous terms and the velocity gradient use L_i. */
    float pgrad_c;
    float g[3];
    float coll_r;             /* collision radius */
    float wall_margin;        /* safety clamp distance inside walls */
    double cfl_dt_hint;

    /* domain and grid */
    float lo[3], hi[3], len[3], half_len[3];
    float wrap_h[3];          /* half_len on periodic axes, +inf otherwise */
    int periodic[3];          /* per axis */
    int any_periodic;
    int face[6];              /* resolved sq_sph_boundary per face */
    int any_wall;
    int n[3];                 /* cells per axis (terrain-following grid: n[2] per column) */
    int column;               /* 1: terrain-following grid; cell = (cy nx + cx) n[2] + k − kbase */
    int32_t *kbase;           /* per column: the absolute z cell (from lo[2]) of its lowest cell */
    float *col_depth, *col_tmp; /* n[0]*n[1]: flow depth per column (Voellmy drag), scratch */
    float cell[3], inv_cell[3];
    uint32_t ncell;
    uint32_t *cell_start;     /* ncell + 2 */

    /* particles */
    size_t cap, count;
    uint32_t next_id;
    float *x, *y, *z;         /* positions */
    float *vx, *vy, *vz;      /* velocity: synchronous after a step, predicted inside it */
    float *hx, *hy, *hz;      /* half-step velocity v_{n+1/2} */
    float *ax, *ay, *az;      /* acceleration */
    float *sx, *sy, *sz;      /* XSPH correction ε Σ ... (velocity units) */
    float *rho, *p, *vol, *pr2; /* density, pressure, m/ρ, p/ρ² */
    float *L;                 /* 6 per particle (xx yy zz xy xz yz): inverse correction */
    float *G;                 /* 9 per particle: velocity gradient (row-major ∂v_a/∂x_b);
                                 TENSOR viscous form only (NULL otherwise) */
    float *tau;               /* 6 per particle: deviatoric stress 2 μ D; TENSOR only */
    float *gam, *mu;          /* |γ̇| and μ */
    /* Packed j-side data of the strain and force passes, 8 floats (32 bytes) per particle:
     * x y z m/ρ vx vy vz p/ρ², written by the density pass (one half cache line per neighbour
     * instead of eight arrays). */
#define SQ__SPH_REC 8
    float *rec;
    uint32_t *id;
    uint32_t *cellid, *perm;  /* cell of each particle (sorted after the sort), permutation */
#define SQ__SPH_NREORDER_F 9
#define SQ__SPH_NREORDER_U 2
    float *fspare[SQ__SPH_NREORDER_F];    /* reorder targets of x y z vx vy vz hx hy hz */
    uint32_t *uspare[SQ__SPH_NREORDER_U]; /* reorder targets of id, cellid */
    uint32_t *nb;             /* nb_cap entries per particle */
    uint16_t *nb_count, *nb_plain;
    int nb_cap;
    uint32_t *hist;           /* ncell + 2 counts */

    /* colliders */
    sq__sph_terrain terrain;
    int has_terrain;
    sq__sph_box *boxes;
    int box_count, box_cap;
    sq__sph_sdf *sdfs;
    int sdf_count;

    /* reductions (per thread) */
    double *red;              /* nt * 8 doubles */

    /* state */
    int forces_valid;
    int logged_substep;
    float vmax, amax, mumax;  /* of the current state */
    uint64_t steps;
    double time_s;
    sq_sph_stats stats;
    uint64_t bytes;
};

/* Cells of one column of the terrain-following grid for a layer of layer_m (sph_desc.c). */
int sq__sph_column_cells(double layer_m, double cell_z);

/* Validates a desc (sph_desc.c); ctx may be NULL. */
sq_result sq__sph_validate(sq_context *ctx, const sq_sph_desc *in);

/* ---- passes (sph_passes.c): pure loops over the arrays of s ------------------------------ */
/* Cell of a position (clamped to the grid; non-finite -> cell 0). */
uint32_t sq__sph_cell_of(const sq_sph *s, float x, float y, float z);
/* Terrain-following grid: true if (x, y, z) lies above the top cell of its column. */
int sq__sph_above_layer(const sq_sph *s, float x, float y, float z);
/* Counting sort by cell, reorder of the persistent arrays, removal of particles outside open
 * faces. Returns the number removed. */
size_t sq__sph_sort(sq_sph *s);
/* Neighbour lists (plain then mirror images), density with self term, pressure.
 * Returns the largest neighbour count seen (may exceed nb_cap: then redo with a larger list). */
int sq__sph_pass_density(sq_sph *s);
/* Whether the passes run the AVX-512 loops: compiled in (-march=native on such a CPU), or chosen
 * at run time in a portable build when the CPU is x86-64-v4 and SQ_SPH_ISA is not "portable". */
int sq__sph_uses_avx512(void);
/* Correction matrices, velocity gradient, |γ̇|, μ and τ. Returns max μ. */
float sq__sph_pass_strain(sq_sph *s);
/* Accelerations (pressure, viscosity/stress, body force) and the XSPH term. Returns max |a|. */
float sq__sph_pass_forces(sq_sph *s);

/* Collisions (sph_collide.c): walls clamp, terrain, boxes; modify position and half-step
 * velocity of particle i. */
void sq__sph_collide(const sq_sph *s, size_t i);
/* After the closing kick: the velocity response for particles resting on a collider. */
void sq__sph_contact_velocity(const sq_sph *s, size_t i);

/* Threads for a loop over n particles: small systems run on one thread, where the fork/join
 * and barrier costs (large on a loaded machine) would exceed the work. */
#define SQ__SPH_PARALLEL_MIN 8192
static inline int sq__sph_threads(const sq_sph *s, size_t n)
{
    return n >= SQ__SPH_PARALLEL_MIN ? s->nt : 1;
}

/* Pressure from density (EOS, clamp). */
static inline float sq__sph_eos(const sq_sph *s, float rho)
{
    float p;
    if (s->tait) p = s->tait_b * (powf(rho / s->rho0, s->tait_gamma) - 1.0f);
    else p = s->c2 * (rho - s->rho0);
    p += s->p_bg;
    if (!s->tensile && p < 0.0f) p = 0.0f;
    return p;
}

#endif
