/* squall/sqmath.h — small vector and matrix math (float), header-only.
 * World axes: right-handed, x east, y north, z up, metres. Matrices are column-major
 * (m[col*4+row]) as OpenGL expects. */
#ifndef SQ_SQMATH_H
#define SQ_SQMATH_H

#include <math.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_vec3 {
    float x, y, z;
} sq_vec3;

typedef struct sq_vec4 {
    float x, y, z, w;
} sq_vec4;

typedef struct sq_mat4 {
    float m[16]; /* column-major */
} sq_mat4;

#define SQ_PI 3.14159265358979323846
#define SQ_PI_F 3.14159265358979323846f

static inline sq_vec3 sq_v3(float x, float y, float z)
{
    sq_vec3 r = {x, y, z};
    return r;
}
static inline sq_vec3 sq_v3_add(sq_vec3 a, sq_vec3 b) { return sq_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline sq_vec3 sq_v3_sub(sq_vec3 a, sq_vec3 b) { return sq_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline sq_vec3 sq_v3_mul(sq_vec3 a, sq_vec3 b) { return sq_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline sq_vec3 sq_v3_scale(sq_vec3 a, float s) { return sq_v3(a.x * s, a.y * s, a.z * s); }
static inline float sq_v3_dot(sq_vec3 a, sq_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline sq_vec3 sq_v3_cross(sq_vec3 a, sq_vec3 b)
{
    return sq_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float sq_v3_len(sq_vec3 a) { return sqrtf(sq_v3_dot(a, a)); }
static inline sq_vec3 sq_v3_norm(sq_vec3 a)
{
    float l = sq_v3_len(a);
    return l > 0.0f ? sq_v3_scale(a, 1.0f / l) : sq_v3(0.0f, 0.0f, 0.0f);
}
static inline sq_vec3 sq_v3_lerp(sq_vec3 a, sq_vec3 b, float t)
{
    return sq_v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}
static inline float sq_clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }
static inline double sq_clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }
static inline int sq_clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

static inline sq_mat4 sq_m4_identity(void)
{
    sq_mat4 r = {{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}};
    return r;
}

static inline sq_mat4 sq_m4_mul(sq_mat4 a, sq_mat4 b)
{
    sq_mat4 r;
    for (int c = 0; c < 4; c++)
        for (int rr = 0; rr < 4; rr++) {
            float s = 0.0f;
            for (int k = 0; k < 4; k++) s += a.m[k * 4 + rr] * b.m[c * 4 + k];
            r.m[c * 4 + rr] = s;
        }
    return r;
}

static inline sq_vec4 sq_m4_mul_v4(sq_mat4 a, sq_vec4 v)
{
    sq_vec4 r;
    r.x = a.m[0] * v.x + a.m[4] * v.y + a.m[8] * v.z + a.m[12] * v.w;
    r.y = a.m[1] * v.x + a.m[5] * v.y + a.m[9] * v.z + a.m[13] * v.w;
    r.z = a.m[2] * v.x + a.m[6] * v.y + a.m[10] * v.z + a.m[14] * v.w;
    r.w = a.m[3] * v.x + a.m[7] * v.y + a.m[11] * v.z + a.m[15] * v.w;
    return r;
}

/* Right-handed view matrix looking from eye to target; up is usually (0,0,1). */
static inline sq_mat4 sq_m4_look_at(sq_vec3 eye, sq_vec3 target, sq_vec3 up)
{
    sq_vec3 f = sq_v3_norm(sq_v3_sub(target, eye));
    sq_vec3 s = sq_v3_norm(sq_v3_cross(f, up));
    sq_vec3 u = sq_v3_cross(s, f);
    sq_mat4 r = sq_m4_identity();
    r.m[0] = s.x; r.m[4] = s.y; r.m[8] = s.z;
    r.m[1] = u.x; r.m[5] = u.y; r.m[9] = u.z;
    r.m[2] = -f.x; r.m[6] = -f.y; r.m[10] = -f.z;
    r.m[12] = -sq_v3_dot(s, eye);
    r.m[13] = -sq_v3_dot(u, eye);
    r.m[14] = sq_v3_dot(f, eye);
    return r;
}

/* OpenGL perspective projection (clip z in [-1, 1]); fovy in radians. */
static inline sq_mat4 sq_m4_perspective(float fovy, float aspect, float znear, float zfar)
{
    float f = 1.0f / tanf(0.5f * fovy);
    sq_mat4 r = {{0}};
    r.m[0] = f / aspect;
    r.m[5] = f;
    r.m[10] = (zfar + znear) / (znear - zfar);
    r.m[11] = -1.0f;
    r.m[14] = 2.0f * zfar * znear / (znear - zfar);
    return r;
}

static inline sq_mat4 sq_m4_ortho(float l, float r_, float b, float t, float n, float f)
{
    sq_mat4 r = sq_m4_identity();
    r.m[0] = 2.0f / (r_ - l);
    r.m[5] = 2.0f / (t - b);
    r.m[10] = -2.0f / (f - n);
    r.m[12] = -(r_ + l) / (r_ - l);
    r.m[13] = -(t + b) / (t - b);
    r.m[14] = -(f + n) / (f - n);
    return r;
}

/* General 4x4 inverse; returns identity if singular. */
static inline sq_mat4 sq_m4_inverse(sq_mat4 a)
{
    const float *m = a.m;
    float inv[16];
    inv[0] = m[5] * m[10] * m[15] - m[5] * m[11] * m[14] - m[9] * m[6] * m[15] + m[9] * m[7] * m[14] + m[13] * m[6] * m[11] - m[13] * m[7] * m[10];
    inv[4] = -m[4] * m[10] * m[15] + m[4] * m[11] * m[14] + m[8] * m[6] * m[15] - m[8] * m[7] * m[14] - m[12] * m[6] * m[11] + m[12] * m[7] * m[10];
    inv[8] = m[4] * m[9] * m[15] - m[4] * m[11] * m[13] - m[8] * m[5] * m[15] + m[8] * m[7] * m[13] + m[12] * m[5] * m[11] - m[12] * m[7] * m[9];
    inv[12] = -m[4] * m[9] * m[14] + m[4] * m[10] * m[13] + m[8] * m[5] * m[14] - m[8] * m[6] * m[13] - m[12] * m[5] * m[10] + m[12] * m[6] * m[9];
    inv[1] = -m[1] * m[10] * m[15] + m[1] * m[11] * m[14] + m[9] * m[2] * m[15] - m[9] * m[3] * m[14] - m[13] * m[2] * m[11] + m[13] * m[3] * m[10];
    inv[5] = m[0] * m[10] * m[15] - m[0] * m[11] * m[14] - m[8] * m[2] * m[15] + m[8] * m[3] * m[14] + m[12] * m[2] * m[11] - m[12] * m[3] * m[10];
    inv[9] = -m[0] * m[9] * m[15] + m[0] * m[11] * m[13] + m[8] * m[1] * m[15] - m[8] * m[3] * m[13] - m[12] * m[1] * m[11] + m[12] * m[3] * m[9];
    inv[13] = m[0] * m[9] * m[14] - m[0] * m[10] * m[13] - m[8] * m[1] * m[14] + m[8] * m[2] * m[13] + m[12] * m[1] * m[10] - m[12] * m[2] * m[9];
    inv[2] = m[1] * m[6] * m[15] - m[1] * m[7] * m[14] - m[5] * m[2] * m[15] + m[5] * m[3] * m[14] + m[13] * m[2] * m[7] - m[13] * m[3] * m[6];
    inv[6] = -m[0] * m[6] * m[15] + m[0] * m[7] * m[14] + m[4] * m[2] * m[15] - m[4] * m[3] * m[14] - m[12] * m[2] * m[7] + m[12] * m[3] * m[6];
    inv[10] = m[0] * m[5] * m[15] - m[0] * m[7] * m[13] - m[4] * m[1] * m[15] + m[4] * m[3] * m[13] + m[12] * m[1] * m[7] - m[12] * m[3] * m[5];
    inv[14] = -m[0] * m[5] * m[14] + m[0] * m[6] * m[13] + m[4] * m[1] * m[14] - m[4] * m[2] * m[13] - m[12] * m[1] * m[6] + m[12] * m[2] * m[5];
    inv[3] = -m[1] * m[6] * m[11] + m[1] * m[7] * m[10] + m[5] * m[2] * m[11] - m[5] * m[3] * m[10] - m[9] * m[2] * m[7] + m[9] * m[3] * m[6];
    inv[7] = m[0] * m[6] * m[11] - m[0] * m[7] * m[10] - m[4] * m[2] * m[11] + m[4] * m[3] * m[10] + m[8] * m[2] * m[7] - m[8] * m[3] * m[6];
    inv[11] = -m[0] * m[5] * m[11] + m[0] * m[7] * m[9] + m[4] * m[1] * m[11] - m[4] * m[3] * m[9] - m[8] * m[1] * m[7] + m[8] * m[3] * m[5];
    inv[15] = m[0] * m[5] * m[10] - m[0] * m[6] * m[9] - m[4] * m[1] * m[10] + m[4] * m[2] * m[9] + m[8] * m[1] * m[6] - m[8] * m[2] * m[5];
    float det = m[0] * inv[0] + m[1] * inv[4] + m[2] * inv[8] + m[3] * inv[12];
    if (det == 0.0f) return sq_m4_identity();
    sq_mat4 r;
    for (int i = 0; i < 16; i++) r.m[i] = inv[i] / det;
    return r;
}

#ifdef __cplusplus
}
#endif
#endif
