/* flip.c — the LDR-FLIP image difference of Andersson, Nilsson, Akenine-Möller, Oskarsson,
 * Åström, Fairchild, "FLIP: A Difference Evaluator for Alternating Images", Proc. ACM Comput.
 * Graph. Interact. Tech. 3(2), 2020 (HPG 2020), written from the paper's description, used with
 * SSIM (image.c) to judge the real-time renderer against the reference path tracer (SPEC §3–4
 * validation, docs/validation.md).
 *
 * Both images (8-bit sRGB) go through the same two pipelines; only the last stages combine them:
 *   colour:  sRGB -> linear RGB -> XYZ -> YyCxCz (linearised CIELAB, D65 white)
 *            -> spatial CSF filter per opponent channel (sums of gaussians, paper Table 1, for
 *               the given pixels per degree; kernel radius from the widest gaussian, b = 0.04,
 *               normalised to unit sum)
 *            -> linear RGB clamped to [0,1] -> CIELAB -> Hunt adjustment (a, b scaled by L/100)
 *            -> HyAB distance |ΔL| + ||Δ(a,b)|| -> power qc = 0.7
 *            -> compression into [0,1]: below pc·cmax linear to pt, above it linear from pt to 1
 *               at cmax (pc = 0.4, pt = 0.95, cmax = the powered HyAB distance between the
 *               Hunt-adjusted green and blue primaries)
 *   feature: Y/Yn (= (Yy + 16) / 116, the paper's erratum) filtered with the first (edges) and
 *            second (points) derivatives of a gaussian of σ = ½·0.082°·ppd pixels, radius ⌈3σ⌉,
 *            each lobe normalised to ±1; ΔE_f = (max(|‖e_r‖−‖e_t‖|, |‖p_r‖−‖p_t‖|) / √2)^qf,
 *            qf = 0.5
 *   ΔE = ΔE_c^(1 − ΔE_f); the metric is the mean of ΔE over the pixels.
 * Borders: the filters clamp coordinates to the image (edge pixels repeat). Every stage treats
 * the two images identically and combines them with symmetric operations, so LDR-FLIP is
 * symmetric in its arguments (exactly here); the asymmetry of FLIP's HDR variant (exposures
 * chosen from the reference) does not arise. All arithmetic is double, serial and
 * deterministic. */
#include <math.h>
#include <string.h>

#include "core/core_internal.h"
#include "squall/render.h"

#define FLIP_DEFAULT_PPD 67.02064327658225 /* 0.7 m from a 0.7 m wide 3840-pixel monitor */
#define FLIP_QC 0.7
#define FLIP_QF 0.5
#define FLIP_PC 0.4
#define FLIP_PT 0.95
#define FLIP_EDGE_WIDTH_DEG 0.082
#define FLIP_CSF_BMAX 0.04

/* spatial CSF per opponent channel (Yy, Cx, Cz): a1, b1, a2, b2 (paper Table 1) */
static const double csf_param[3][4] = {
    {1.0, 0.0047, 0.0, 1.0e-5},   /* achromatic */
    {1.0, 0.0053, 0.0, 1.0e-5},   /* red-green */
    {34.1, 0.04, 13.5, 0.025},    /* blue-yellow */
};

/* linear sRGB (D65) -> XYZ */
static const double rgb2xyz[3][3] = {
    {0.4124564, 0.3575761, 0.1804375},
    {0.2126729, 0.7151522, 0.0721750},
    {0.0193339, 0.1191920, 0.9503041},
};

typedef struct flip_colour {
    double xyz2rgb[3][3];
    double white[3]; /* XYZ of RGB (1,1,1): the reference white of both Lab spaces */
} flip_colour;

static void colour_init(flip_colour *c)
{
    const double(*m)[3] = rgb2xyz;
    for (int i = 0; i < 3; i++) c->white[i] = m[i][0] + m[i][1] + m[i][2];
    const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            /* inverse = adjugate / det: cofactor of (j, i) */
            const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            c->xyz2rgb[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
        }
}

static double srgb_decode(uint8_t v)
{
    const double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static double lab_f(double t)
{
    const double d = 6.0 / 29.0;
    return t > d * d * d ? cbrt(t) : t / (3.0 * d * d) + 4.0 / 29.0;
}

/* linear RGB -> Hunt-adjusted CIELAB */
static void rgb_to_hunt_lab(const flip_colour *c, const double rgb[3], double out[3])
{
    double f[3];
    for (int i = 0; i < 3; i++) {
        const double t = rgb2xyz[i][0] * rgb[0] + rgb2xyz[i][1] * rgb[1] + rgb2xyz[i][2] * rgb[2];
        f[i] = lab_f(t / c->white[i]);
    }
    const double L = 116.0 * f[1] - 16.0;
    out[0] = L;
    out[1] = 0.01 * L * (500.0 * (f[0] - f[1]));
    out[2] = 0.01 * L * (200.0 * (f[1] - f[2]));
}

static double hyab(const double a[3], const double b[3])
{
    const double da = a[1] - b[1], db = a[2] - b[2];
    return fabs(a[0] - b[0]) + sqrt(da * da + db * db);
}

/* Separable convolution with coordinate clamping: out = ky (columns) * (kx (rows) * in). */
static void conv_sep(const double *in, double *tmp, double *out, int w, int h, const double *kx,
                     const double *ky, int r)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0;
            for (int i = -r; i <= r; i++) {
                int xx = x + i;
                xx = xx < 0 ? 0 : (xx >= w ? w - 1 : xx);
                s += kx[i + r] * in[(size_t)y * w + xx];
            }
            tmp[(size_t)y * w + x] = s;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s = 0.0;
            for (int i = -r; i <= r; i++) {
                int yy = y + i;
                yy = yy < 0 ? 0 : (yy >= h ? h - 1 : yy);
                s += ky[i + r] * tmp[(size_t)yy * w + x];
            }
            out[(size_t)y * w + x] = s;
        }
}

/* Scales the positive entries of k to sum 1 and the negative ones to sum -1. */
static void normalise_lobes(double *k, int n)
{
    double pos = 0.0, neg = 0.0;
    for (int i = 0; i < n; i++) {
        if (k[i] > 0.0) pos += k[i];
        else neg -= k[i];
    }
    for (int i = 0; i < n; i++) k[i] = k[i] > 0.0 ? k[i] / pos : (neg > 0.0 ? k[i] / neg : 0.0);
}

/* Per image: the Hunt-adjusted Lab of the CSF-filtered image (3 planes) and the edge and point
 * magnitudes of its luminance (2 planes, after Y/Yn itself). Scratch: 5 planes. */
typedef struct flip_kernels {
    int rc, rf;
    double *csf[2];               /* scratch: 1D gaussians exp(-π² x² / b), b = b1, b2 */
    double *gauss, *edge, *point; /* feature kernels */
} flip_kernels;

static void prepare_image(const flip_colour *c, const flip_kernels *k, const uint8_t *rgba, int w,
                          int h, double ppd, double *lab, double *feat, double *scratch)
{
    const size_t n = (size_t)w * h;
    double *ycc = scratch, *tmp = scratch + 3 * n, *acc = lab; /* lab planes reused as output */
    double *lum = feat;                                        /* Y / Yn before the filters */
    /* sRGB -> YyCxCz */
    for (size_t p = 0; p < n; p++) {
        const double rgb[3] = {srgb_decode(rgba[4 * p]), srgb_decode(rgba[4 * p + 1]),
                               srgb_decode(rgba[4 * p + 2])};
        double t[3];
        for (int i = 0; i < 3; i++)
            t[i] = (rgb2xyz[i][0] * rgb[0] + rgb2xyz[i][1] * rgb[1] + rgb2xyz[i][2] * rgb[2]) /
                   c->white[i];
        ycc[p] = 116.0 * t[1] - 16.0;
        ycc[n + p] = 500.0 * (t[0] - t[1]);
        ycc[2 * n + p] = 200.0 * (t[1] - t[2]);
        lum[p] = t[1];
    }
    /* CSF filtering: kernel Σ_j a_j sqrt(π/b_j) g_j(x) g_j(y), normalised to unit sum */
    const int rc = k->rc, len = 2 * rc + 1;
    double *const g[2] = {k->csf[0], k->csf[1]};
    for (int ch = 0; ch < 3; ch++) {
        const double *par = csf_param[ch];
        double wj[2], sum2d = 0.0;
        for (int j = 0; j < 2; j++) {
            const double a = par[2 * j], b = par[2 * j + 1];
            double s = 0.0;
            for (int i = 0; i < len; i++) {
                const double x = (i - rc) / ppd;
                g[j][i] = exp(-SQ_PI * SQ_PI * x * x / b);
                s += g[j][i];
            }
            wj[j] = a * sqrt(SQ_PI / b);
            sum2d += wj[j] * s * s;
        }
        double *dst = acc + (size_t)ch * n;
        memset(dst, 0, n * sizeof(double));
        for (int j = 0; j < 2; j++) {
            if (wj[j] == 0.0) continue;
            conv_sep(ycc + (size_t)ch * n, tmp, tmp + n, w, h, g[j], g[j], rc);
            const double s = wj[j] / sum2d;
            for (size_t p = 0; p < n; p++) dst[p] += s * tmp[n + p];
        }
    }
    /* filtered YyCxCz -> linear RGB (clamped) -> Hunt-adjusted Lab, in place */
    for (size_t p = 0; p < n; p++) {
        const double yr = (acc[p] + 16.0) / 116.0;
        const double t[3] = {(acc[n + p] / 500.0 + yr) * c->white[0], yr * c->white[1],
                             (yr - acc[2 * n + p] / 200.0) * c->white[2]};
        double rgb[3], out[3];
        for (int i = 0; i < 3; i++) {
            const double v = c->xyz2rgb[i][0] * t[0] + c->xyz2rgb[i][1] * t[1] +
                             c->xyz2rgb[i][2] * t[2];
            rgb[i] = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
        }
        rgb_to_hunt_lab(c, rgb, out);
        acc[p] = out[0];
        acc[n + p] = out[1];
        acc[2 * n + p] = out[2];
    }
    /* features of Y/Yn: edge and point magnitudes (x and y derivative responses) */
    const int rf = k->rf;
    double *dx = scratch, *dy = scratch + n, *t2 = scratch + 2 * n;
    conv_sep(lum, t2, dx, w, h, k->edge, k->gauss, rf);
    conv_sep(lum, t2, dy, w, h, k->gauss, k->edge, rf);
    double *edge = feat + n, *point = feat + 2 * n;
    for (size_t p = 0; p < n; p++) edge[p] = sqrt(dx[p] * dx[p] + dy[p] * dy[p]);
    conv_sep(lum, t2, dx, w, h, k->point, k->gauss, rf);
    conv_sep(lum, t2, dy, w, h, k->gauss, k->point, rf);
    for (size_t p = 0; p < n; p++) point[p] = sqrt(dx[p] * dx[p] + dy[p] * dy[p]);
}

double sq_image_flip_maps(const uint8_t *reference_rgba, const uint8_t *test_rgba, int width,
                          int height, double pixels_per_degree, float *error_map,
                          float *colour_map, float *feature_map)
{
    if (!reference_rgba || !test_rgba || width <= 0 || height <= 0) {
        sq__set_error(SQ_ERR_INVALID_ARG, "flip: images missing or %d x %d; need > 0", width,
                      height);
        return NAN;
    }
    double ppd = pixels_per_degree;
    if (ppd == 0.0) ppd = FLIP_DEFAULT_PPD;
    if (!(ppd >= 1.0 && ppd <= 300.0)) {
        sq__set_error(SQ_ERR_INVALID_ARG,
                      "flip: pixels_per_degree = %g; must be in [1, 300] (0 selects %.2f: 0.7 m "
                      "from a 0.7 m wide 3840-pixel monitor)",
                      pixels_per_degree, FLIP_DEFAULT_PPD);
        return NAN;
    }
    flip_colour col;
    colour_init(&col);

    flip_kernels k;
    k.rc = (int)ceil(3.0 * sqrt(FLIP_CSF_BMAX / (2.0 * SQ_PI * SQ_PI)) * ppd);
    const double sd = 0.5 * FLIP_EDGE_WIDTH_DEG * ppd;
    k.rf = (int)ceil(3.0 * sd);
    const int lf = 2 * k.rf + 1, lc = 2 * k.rc + 1;
    const size_t n = (size_t)width * height;
    const size_t kern = 3 * (size_t)lf + 2 * (size_t)lc;
    double *buf = (double *)sq_alloc(NULL, (kern + 2 * 6 * n + 5 * n) * sizeof(double));
    if (!buf) {
        sq__set_error(SQ_ERR_OUT_OF_MEMORY, "flip: no memory for %d x %d images", width, height);
        return NAN;
    }
    k.gauss = buf;
    k.edge = buf + lf;
    k.point = buf + 2 * lf;
    k.csf[0] = buf + 3 * lf;
    k.csf[1] = buf + 3 * lf + lc;
    double gs = 0.0;
    for (int i = 0; i < lf; i++) {
        const double x = i - k.rf, g = exp(-x * x / (2.0 * sd * sd));
        k.gauss[i] = g;
        k.edge[i] = -x * g;
        k.point[i] = (x * x / (sd * sd) - 1.0) * g;
        gs += g;
    }
    for (int i = 0; i < lf; i++) k.gauss[i] /= gs;
    normalise_lobes(k.edge, lf);
    normalise_lobes(k.point, lf);

    double *ref = buf + kern, *tst = ref + 6 * n, *scratch = tst + 6 * n;
    prepare_image(&col, &k, reference_rgba, width, height, ppd, ref, ref + 3 * n, scratch);
    prepare_image(&col, &k, test_rgba, width, height, ppd, tst, tst + 3 * n, scratch);

    /* cmax: powered HyAB distance between Hunt-adjusted green and blue */
    double green[3], blue[3];
    const double g_rgb[3] = {0.0, 1.0, 0.0}, b_rgb[3] = {0.0, 0.0, 1.0};
    rgb_to_hunt_lab(&col, g_rgb, green);
    rgb_to_hunt_lab(&col, b_rgb, blue);
    const double cmax = pow(hyab(green, blue), FLIP_QC);
    const double knee = FLIP_PC * cmax;

    double total = 0.0;
    for (int y = 0; y < height; y++) {
        double row = 0.0;
        for (int x = 0; x < width; x++) {
            const size_t p = (size_t)y * width + x;
            const double a[3] = {ref[p], ref[n + p], ref[2 * n + p]};
            const double b[3] = {tst[p], tst[n + p], tst[2 * n + p]};
            const double e = pow(hyab(a, b), FLIP_QC);
            const double dc = e < knee ? FLIP_PT / knee * e
                                       : FLIP_PT + (e - knee) / (cmax - knee) * (1.0 - FLIP_PT);
            const double de = fabs(ref[4 * n + p] - tst[4 * n + p]);
            const double dp = fabs(ref[5 * n + p] - tst[5 * n + p]);
            const double df = pow((de > dp ? de : dp) / sqrt(2.0), FLIP_QF);
            const double flip = pow(dc, 1.0 - df);
            if (error_map) error_map[p] = (float)flip;
            if (colour_map) colour_map[p] = (float)dc;
            if (feature_map) feature_map[p] = (float)df;
            row += flip;
        }
        total += row;
    }
    sq_free(NULL, buf);
    return total / (double)n;
}

double sq_image_flip(const uint8_t *reference_rgba, const uint8_t *test_rgba, int width,
                     int height, double pixels_per_degree)
{
    return sq_image_flip_maps(reference_rgba, test_rgba, width, height, pixels_per_degree, NULL,
                              NULL, NULL);
}
