/* clouds_light.c — lighting of cloud particles on the CPU (SPEC 8.4–8.5; Harris & Lastra 2001,
 * "Real-time cloud rendering", and Harris's SkyWorks code):
 *
 *   1. Sun sweep. A light buffer spans the particles' discs on the plane across the light
 *      (orthographic: the sun is a directional source). Particles are visited in order of
 *      their distance along the light's propagation direction. Particle k first reads the
 *      buffer at its centre: I_k, the light reaching it. It then splats itself into the buffer
 *      with its opacity alpha(t) (splat falloff eta(t), t = texel distance / radius):
 *          B <- g_k(t) + T_k(t) B,   T_k = 1 - alpha_k,   g_k = a alpha_k F I_k,
 *      where F = min(1, p(0) gamma) is the share of the scattered light kept in the forward
 *      cone gamma (Harris's a tau p(l, -l) gamma / 4 pi with p normalised to 4 pi; 1 - e^-tau
 *      instead of tau so that an opaque particle never adds light). Along one ray this is
 *      eq. (4) with the causal index: I_k = g_{k-1} + T_{k-1} I_{k-1}, I_1 = I_0 = 1.
 *      A second buffer carries the plain Beer transmittance (no in-scatter) for the diffuse
 *      term; the sun buffer after the last particle is the clouds' shadow on the ground.
 *   2. Diffuse light (view.multiple_scattering). Harris MFS keeps only the forward peak; the
 *      light scattered out of it diffuses through the cloud. Along the particle's sun ray the
 *      cloud has the (delta-scaled) optical depth S = (1 - g) tau_t in all (tau_t from the
 *      final Beer buffer at the particle) and s = (1 - g) tau_s between the particle and the
 *      sunlit edge. A conservative Eddington slab of that depth transmits T = 1 / (1 + 3/4 S)
 *      and reflects R = 1 - T. Its diffuse field leaves the lit face with radiance E R and the
 *      shadowed face with E T, one hemisphere filled at each face, so the mean (angle-averaged)
 *      diffuse radiance that a particle scatters falls about linearly from E R / 2 at the lit
 *      face to E T / 2 at the shadowed one:
 *          J_d = E (1 - e^-S) (T + R (1 - s / S)) / 2,
 *      the first factor taking it to zero where the cloud is thin for the delta-scaled depth:
 *      there the scattered light stays in the forward peak, which the MFS term carries.
 *   3. Zenith sweep for the sky's ambient light: Beer transmittance from above turned into the
 *      two-stream transmission of diffuse light, 1 / (1 + 3/4 (1 - g) tau_up).
 * Buffer resolution: light_buffer texels per side at most, and no finer than the particles'
 * mean radius / light_texels_per_radius (4): a splat touches ~50 texels whatever the domain, so
 * the sweeps cost O(particles). Each splat uses 33-point radial tables of eta and of its texel
 * opacity (no exponential per texel). The sun and zenith sweeps run on two threads.
 * Splat cross-sections: a particle's splat carries the attenuation cross-section of the
 * continuous sprite, integral of tau eta(t) dA = 0.3 pi r² tau (integral of 2t³ - 3t² + 1 over
 * the unit disc is 0.3 pi): on the texel grid the per-texel optical depths are scaled by
 * 0.3 pi r² / (h² sum eta(t_i)), and a disc smaller than a texel centre's reach goes to the
 * nearest texel, so coarse buffers neither lose nor invent cloud. */
#include <math.h>
#include <string.h>

#include "render/clouds_light.h"

#define PI_F 3.14159265358979f
#define SPLAT_AREA 0.3f   /* integral of eta(t) over the unit disc / pi */
#define LIGHT_DEFAULT 512
#define LIGHT_MAX 4096

float sq__cloud_splat(float t)
{
    const float a = fabsf(t);
    if (!(a < 1.0f)) return 0.0f;
    return (2.0f * a - 3.0f) * a * a + 1.0f;
}

float sq__cloud_alpha(const sq_clouds_view *v, float tau, float t)
{
    const float s = sq__cloud_splat(t);
    if (v->splat_opacity) {
        const float a = -expm1f(-v->tau_splat) * v->eta1 * s;
        return a < 0.0f ? 0.0f : (a > 1.0f ? 1.0f : a);
    }
    return -expm1f(-tau * s);
}

float sq__cloud_phase(const sq_clouds_view *v, float g, float cos_theta)
{
    if (v->rayleigh) return 3.0f * (1.0f + cos_theta * cos_theta) / (16.0f * PI_F);
    const float d = 1.0f + g * g - 2.0f * g * cos_theta;
    return (1.0f - g * g) / (4.0f * PI_F * d * sqrtf(d));
}

float sq__cloud_forward_fraction(const sq_clouds_view *v, float g)
{
    const float f = sq__cloud_phase(v, g, 1.0f) * v->gamma_sr;
    return f > 1.0f ? 1.0f : f;
}

float sq__cloud_impostor_weight(float d, float dist_3d, float dist_impostor)
{
    if (!(dist_impostor > dist_3d)) return d >= dist_impostor ? 1.0f : 0.0f;
    float t = (d - dist_3d) / (dist_impostor - dist_3d);
    t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
    return t * t * (3.0f - 2.0f * t);
}

/* ---- workspace ---------------------------------------------------------------------------- */
void sq__cloud_light_free(sq_context *ctx, sq__cloud_light *L)
{
    sq_free(ctx, L->sun);
    sq_free(ctx, L->direct);
    sq_free(ctx, L->diffuse);
    sq_free(ctx, L->sky);
    sq_free(ctx, L->key);
    sq_free(ctx, L->idx);
    sq_free(ctx, L->key2);
    sq_free(ctx, L->idx2);
    sq_free(ctx, L->key_s);
    sq_free(ctx, L->idx_s);
    sq_free(ctx, L->key_s2);
    sq_free(ctx, L->idx_s2);
    sq_free(ctx, L->shadow);
    sq_free(ctx, L->buf_d);
    sq_free(ctx, L->buf_sky);
    memset(L, 0, sizeof *L);
}

static sq_result reserve(sq_context *ctx, sq__cloud_light *L, size_t n, size_t texels)
{
    if (n > L->cap) {
        sq_free(ctx, L->sun);
        sq_free(ctx, L->direct);
        sq_free(ctx, L->diffuse);
        sq_free(ctx, L->sky);
        sq_free(ctx, L->key);
        sq_free(ctx, L->idx);
        sq_free(ctx, L->key2);
        sq_free(ctx, L->idx2);
        sq_free(ctx, L->key_s);
        sq_free(ctx, L->idx_s);
        sq_free(ctx, L->key_s2);
        sq_free(ctx, L->idx_s2);
        const size_t cap = n + n / 4 + 256;
        L->sun = sq_alloc(ctx, cap * sizeof(float));
        L->direct = sq_alloc(ctx, cap * sizeof(float));
        L->diffuse = sq_alloc(ctx, cap * sizeof(float));
        L->sky = sq_alloc(ctx, cap * sizeof(float));
        L->key = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->idx = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->key2 = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->idx2 = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->key_s = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->idx_s = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->key_s2 = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->idx_s2 = sq_alloc(ctx, cap * sizeof(uint32_t));
        L->cap = cap;
        if (!L->sun || !L->direct || !L->diffuse || !L->sky || !L->key || !L->idx || !L->key2 ||
            !L->idx2 || !L->key_s || !L->idx_s || !L->key_s2 || !L->idx_s2) {
            L->cap = 0;
            return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                            "cloud light: no memory for %zu particles", n);
        }
    }
    if (texels > L->buf_cap) {
        sq_free(ctx, L->shadow);
        sq_free(ctx, L->buf_d);
        sq_free(ctx, L->buf_sky);
        L->shadow = sq_alloc(ctx, texels * sizeof(float));
        L->buf_d = sq_alloc(ctx, texels * sizeof(float));
        L->buf_sky = sq_alloc(ctx, texels * sizeof(float));
        L->buf_cap = texels;
        if (!L->shadow || !L->buf_d || !L->buf_sky) {
            L->buf_cap = 0;
            return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                            "cloud light: no memory for a light buffer of %zu texels", texels);
        }
    }
    return SQ_OK;
}

/* ---- one sweep ------------------------------------------------------------------------------ */
typedef struct sweep {
    sq_vec3 l, e1, e2;  /* propagation direction and the buffer's axes */
    float u0, v0, h;    /* buffer origin (texel (0,0) corner) and texel size */
    int nx, ny;
} sweep;

static void sweep_frame(const sq_clouds_view *v, sq_vec3 l, int size, float min_texel, sweep *s)
{
    s->l = sq_v3_norm(l);
    const sq_vec3 ref = fabsf(s->l.z) < 0.99f ? sq_v3(0.0f, 0.0f, 1.0f) : sq_v3(1.0f, 0.0f, 0.0f);
    s->e1 = sq_v3_norm(sq_v3_cross(ref, s->l));
    s->e2 = sq_v3_cross(s->l, s->e1);
    float u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
    for (int i = 0; i < v->count; i++) {
        const float *p = v->position + 3 * i;
        const sq_vec3 x = sq_v3(p[0], p[1], p[2]);
        const float r = v->radius_m[i];
        const float u = sq_v3_dot(x, s->e1), w = sq_v3_dot(x, s->e2);
        u0 = fminf(u0, u - r);
        u1 = fmaxf(u1, u + r);
        v0 = fminf(v0, w - r);
        v1 = fmaxf(v1, w + r);
    }
    const float ext = fmaxf(u1 - u0, v1 - v0);
    s->h = ext > 0.0f ? fmaxf(ext / (float)size, min_texel) : 1.0f;
    /* one texel of margin on each side: bilinear reads at the edge see a clear border */
    s->u0 = u0 - s->h;
    s->v0 = v0 - s->h;
    s->nx = (int)ceilf((u1 - u0) / s->h) + 2;
    s->ny = (int)ceilf((v1 - v0) / s->h) + 2;
    if (s->nx > size + 2) s->nx = size + 2;
    if (s->ny > size + 2) s->ny = size + 2;
}

/* Bilinear read at (u, v) in world units of the buffer plane; outside = 1 (clear). */
static float buf_read(const sweep *s, const float *b, float u, float v)
{
    const float fx = (u - s->u0) / s->h - 0.5f, fy = (v - s->v0) / s->h - 0.5f;
    const int ix = (int)floorf(fx), iy = (int)floorf(fy);
    const float ax = fx - (float)ix, ay = fy - (float)iy;
    float val[4];
    for (int q = 0; q < 4; q++) {
        const int x = ix + (q & 1), y = iy + (q >> 1);
        val[q] = x < 0 || y < 0 || x >= s->nx || y >= s->ny ? 1.0f : b[(size_t)y * s->nx + x];
    }
    return (val[0] * (1.0f - ax) + val[1] * ax) * (1.0f - ay) +
           (val[2] * (1.0f - ax) + val[3] * ax) * ay;
}

/* Radial tables of one splat over q = t² in [0, 1] (LUT + 1 points, linear between): the
 * falloff eta and the texel opacity; 33 exponentials per particle instead of one per texel. */
#define LUT 32

typedef struct footprint {
    int x0, x1, y0, y1; /* inclusive texel range */
    float cu, cv, inv_r2;
    float scale;        /* optical-depth (or alpha) scale per texel (cross-section kept) */
    int nearest_x, nearest_y; /* used when no texel centre lies inside the disc */
    bool nearest;
    float eta[LUT + 1], alpha[LUT + 1];
} footprint;

static float lut_at(const float *t, float q)
{
    const float x = q * (float)LUT;
    int i = (int)x;
    if (i >= LUT) i = LUT - 1;
    const float w = x - (float)i;
    return t[i] + (t[i + 1] - t[i]) * w;
}

/* Per-texel opacity of the particle given eta at the texel. The physical opacity scales the
 * optical depth; the splat opacity (Harris/S4) scales the alpha, as the sum of alphas is the
 * cross-section in the optically thin limit. */
static float texel_alpha(const sq_clouds_view *v, float tau, float eta, float scale)
{
    if (v->splat_opacity) {
        const float a = -expm1f(-v->tau_splat) * v->eta1 * eta * scale;
        return a > 1.0f ? 1.0f : a;
    }
    return -expm1f(-tau * eta * scale);
}

static void footprint_of(const sweep *s, const sq_clouds_view *v, float tau, float u, float w,
                         float r, footprint *f)
{
    f->cu = u;
    f->cv = w;
    f->inv_r2 = 1.0f / (r * r);
    f->x0 = (int)floorf((u - r - s->u0) / s->h);
    f->x1 = (int)floorf((u + r - s->u0) / s->h);
    f->y0 = (int)floorf((w - r - s->v0) / s->h);
    f->y1 = (int)floorf((w + r - s->v0) / s->h);
    if (f->x0 < 0) f->x0 = 0;
    if (f->y0 < 0) f->y0 = 0;
    if (f->x1 >= s->nx) f->x1 = s->nx - 1;
    if (f->y1 >= s->ny) f->y1 = s->ny - 1;
    for (int i = 0; i <= LUT; i++) f->eta[i] = sq__cloud_splat(sqrtf((float)i / (float)LUT));
    double sum = 0.0;
    for (int y = f->y0; y <= f->y1; y++) {
        const float dv = s->v0 + ((float)y + 0.5f) * s->h - w;
        for (int x = f->x0; x <= f->x1; x++) {
            const float du = s->u0 + ((float)x + 0.5f) * s->h - u;
            const float q = (du * du + dv * dv) * f->inv_r2;
            if (q < 1.0f) sum += (double)lut_at(f->eta, q);
        }
    }
    const double want = (double)(SPLAT_AREA * PI_F * r * r) / ((double)s->h * (double)s->h);
    f->nearest = !(sum > 0.0);
    if (f->nearest) {
        int x = (int)floorf((u - s->u0) / s->h), y = (int)floorf((w - s->v0) / s->h);
        f->nearest_x = x < 0 ? 0 : (x >= s->nx ? s->nx - 1 : x);
        f->nearest_y = y < 0 ? 0 : (y >= s->ny ? s->ny - 1 : y);
        f->scale = (float)want; /* the whole cross-section on one texel */
        f->alpha[0] = texel_alpha(v, tau, 1.0f, f->scale);
        return;
    }
    f->scale = (float)(want / sum);
    for (int i = 0; i <= LUT; i++) f->alpha[i] = texel_alpha(v, tau, f->eta[i], f->scale);
}

static float particle_tau(const sq_clouds_view *v, int i) { return v->tau ? v->tau[i] : 0.0f; }
static float particle_g(const sq_clouds_view *v, int i)
{
    return v->g ? v->g[i] : v->g_default;
}

/* The splat loop of one particle: mfs (may be NULL) gets g + T B with g = a alpha F I_k;
 * beer gets T B. */
static void splat(const sweep *s, const footprint *f, float gain, float *mfs, float *beer)
{
    if (f->nearest) {
        const size_t c = (size_t)f->nearest_y * (size_t)s->nx + (size_t)f->nearest_x;
        const float a = f->alpha[0];
        if (mfs) mfs[c] = gain * a + (1.0f - a) * mfs[c];
        beer[c] *= 1.0f - a;
        return;
    }
    for (int y = f->y0; y <= f->y1; y++) {
        const float dv = s->v0 + ((float)y + 0.5f) * s->h - f->cv;
        float *rowm = mfs ? mfs + (size_t)y * (size_t)s->nx : NULL;
        float *rowb = beer + (size_t)y * (size_t)s->nx;
        for (int x = f->x0; x <= f->x1; x++) {
            const float du = s->u0 + ((float)x + 0.5f) * s->h - f->cu;
            const float q = (du * du + dv * dv) * f->inv_r2;
            if (q >= 1.0f) continue;
            const float a = lut_at(f->alpha, q);
            if (rowm) rowm[x] = gain * a + (1.0f - a) * rowm[x];
            rowb[x] *= 1.0f - a;
        }
    }
}

/* Sorts the particles by distance along l into (key, idx) with scratch (k2, i2). */
static void sort_into(const sq_clouds_view *v, sq_vec3 l, uint32_t *key, uint32_t *idx,
                      uint32_t *k2, uint32_t *i2)
{
    const size_t n = (size_t)v->count;
    for (size_t i = 0; i < n; i++) {
        const float *p = v->position + 3 * i;
        key[i] = sq__float_sort_key(p[0] * l.x + p[1] * l.y + p[2] * l.z);
        idx[i] = (uint32_t)i;
    }
    sq__radix_sort_u32(key, idx, k2, i2, n);
}

/* The sun sweep: I_k, Beer transmittance, the shadow buffer (section 1 of the banner). */
static void sun_sweep(sq__cloud_light *L, const sq_clouds_view *v, const sweep *s)
{
    const size_t nt = (size_t)s->nx * (size_t)s->ny;
    for (size_t c = 0; c < nt; c++) L->shadow[c] = L->buf_d[c] = 1.0f;
    sort_into(v, s->l, L->key, L->idx, L->key2, L->idx2);
    for (int q = 0; q < v->count; q++) {
        const int i = (int)L->idx[q];
        const float *p = v->position + 3 * i;
        const sq_vec3 x = sq_v3(p[0], p[1], p[2]);
        const float u = sq_v3_dot(x, s->e1), w = sq_v3_dot(x, s->e2);
        const float I = buf_read(s, L->shadow, u, w);
        L->sun[i] = I;
        L->direct[i] = buf_read(s, L->buf_d, u, w);
        footprint f;
        footprint_of(s, v, particle_tau(v, i), u, w, v->radius_m[i], &f);
        const float gain = v->albedo * sq__cloud_forward_fraction(v, particle_g(v, i)) * I;
        splat(s, &f, gain, L->shadow, L->buf_d);
    }
}

/* The zenith sweep: optical depth above each particle -> two-stream sky transmission. */
static void sky_sweep(sq__cloud_light *L, const sq_clouds_view *v, const sweep *z)
{
    const size_t nz = (size_t)z->nx * (size_t)z->ny;
    for (size_t c = 0; c < nz; c++) L->buf_sky[c] = 1.0f;
    sort_into(v, z->l, L->key_s, L->idx_s, L->key_s2, L->idx_s2);
    for (int q = 0; q < v->count; q++) {
        const int i = (int)L->idx_s[q];
        const float *p = v->position + 3 * i;
        const sq_vec3 x = sq_v3(p[0], p[1], p[2]);
        const float u = sq_v3_dot(x, z->e1), w = sq_v3_dot(x, z->e2);
        const float tau_up = -logf(fmaxf(buf_read(z, L->buf_sky, u, w), 1e-30f));
        L->sky[i] = 1.0f / (1.0f + 0.75f * (1.0f - particle_g(v, i)) * tau_up);
        footprint f;
        footprint_of(z, v, particle_tau(v, i), u, w, v->radius_m[i], &f);
        splat(z, &f, 0.0f, NULL, L->buf_sky);
    }
}

sq_result sq__cloud_light_compute(sq_context *ctx, sq__cloud_light *L, const sq_clouds_view *v,
                                  sq_vec3 sun_dir)
{
    const int n = v->count;
    int size = v->light_buffer > 0 ? v->light_buffer : LIGHT_DEFAULT;
    if (size > LIGHT_MAX) size = LIGHT_MAX;
    const size_t texels = (size_t)(size + 2) * (size_t)(size + 2);
    sq_result res = reserve(ctx, L, (size_t)(n > 0 ? n : 1), texels);
    if (res != SQ_OK) return res;
    L->n = n;
    L->comparisons = 0;
    if (n == 0) {
        L->nx = L->ny = 1;
        L->shadow[0] = 1.0f;
        L->shadow_matrix = sq_m4_identity();
        L->texel_m = 1.0f;
        return SQ_OK;
    }
    /* texels no finer than a fraction of the mean radius: a splat covers at most ~(2k)² texels
     * (k = light_texels_per_radius, 4 by default), whatever the domain */
    double rsum = 0.0;
    for (int i = 0; i < n; i++) rsum += (double)v->radius_m[i];
    const float k = v->light_texels_per_radius > 0.0f ? v->light_texels_per_radius : 4.0f;
    const float min_texel = (float)(rsum / n) / k;
    sweep s, z;
    sweep_frame(v, sq_v3_scale(sq_v3_norm(sun_dir), -1.0f), size, min_texel, &s);
    sweep_frame(v, sq_v3(0.0f, 0.0f, -1.0f), size, min_texel, &z);
    /* the two sweeps are independent: one thread each */
    const bool sky = v->multiple_scattering;
    const int nt = sq_context_threads(ctx) > 1 && sky ? 2 : 1;
    SQ_OMP(omp parallel for schedule(static, 1) num_threads(nt))
    for (int job = 0; job < 2; job++) {
        if (job == 0) sun_sweep(L, v, &s);
        else if (sky) sky_sweep(L, v, &z);
    }
    L->nx = s.nx;
    L->ny = s.ny;
    L->texel_m = s.h;
    /* world -> shadow-map coordinates: u = (x.e1 - u0) / (nx h), v = (x.e2 - v0) / (ny h) */
    sq_mat4 m = sq_m4_identity();
    const float sx = 1.0f / ((float)s.nx * s.h), sy = 1.0f / ((float)s.ny * s.h);
    m.m[0] = s.e1.x * sx;
    m.m[4] = s.e1.y * sx;
    m.m[8] = s.e1.z * sx;
    m.m[12] = -s.u0 * sx;
    m.m[1] = s.e2.x * sy;
    m.m[5] = s.e2.y * sy;
    m.m[9] = s.e2.z * sy;
    m.m[13] = -s.v0 * sy;
    m.m[2] = m.m[6] = m.m[10] = m.m[14] = 0.0f;
    L->shadow_matrix = m;

    /* 2. the diffuse share */
    if (!sky) {
        for (int i = 0; i < n; i++) {
            L->diffuse[i] = 0.0f;
            L->sky[i] = 1.0f;
        }
        return SQ_OK;
    }
    for (int q = 0; q < n; q++) {
        const int i = (int)L->idx[q]; /* in sun order: the same reads as the sweep */
        const float *p = v->position + 3 * i;
        const sq_vec3 x = sq_v3(p[0], p[1], p[2]);
        const float tau_t = -logf(fmaxf(buf_read(&s, L->buf_d, sq_v3_dot(x, s.e1),
                                                 sq_v3_dot(x, s.e2)), 1e-30f));
        const float tau_s = fminf(-logf(fmaxf(L->direct[i], 1e-30f)), tau_t);
        const float kg = 1.0f - particle_g(v, i);
        const float S = kg * tau_t, T = 1.0f / (1.0f + 0.75f * S), R = 1.0f - T;
        const float depth = S > 1e-6f ? kg * tau_s / S : 0.0f;
        L->diffuse[i] = 0.5f * -expm1f(-S) * (T + R * (1.0f - depth));
    }
    return SQ_OK;
}
