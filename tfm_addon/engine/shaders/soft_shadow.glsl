// Soft shadows from a light's size (SOFT_SHADOW 1; light.soft_extent): the light seen as a shape
// across its face, u_soft_extent half-widths (perspective faces: metres in the face's plane; a sun:
// the tangent of half its angle), a rectangle or (u_soft_round) an ellipse. Included by common.glsl.
//
// A light point e and a receiver at distance r: the ray between them crosses the face's centre ray
// through map coordinates uv + e * spread * uv_per_unit, where spread = 1/z - 1/r (perspective,
// z the distance of what it crosses there; divided by the receiver's cos to the face axis) or
// r - z (a sun). The solids' shadow is percentage-closer soft shadowing: a blocker search over the
// footprint of the nearest caster (u_soft_near), then a filter over the light's shape scaled by the
// blockers' mean spread. The medium's transmittance is the map read through points of the light's
// shape scaled by the spread of the medium's middle along the ray (transmittance.glsl): one point
// per sample of the medium, whose view march and antialiasing samples average the shape (a frame
// costs 1.3-1.5 times a sharp one on llvmpipe, docs/benchmark.md). The points come from the R2
// sequence, started per pixel and sample by a hash. A spot's cone is read from a point of the
// light's shape per call too, as Cycles reads it from the light point it samples: its edge is soft.
// An area light's emission: the solid angle its rectangle fills (area_emission), with its spread.
#ifndef SOFT_SHADOW
#define SOFT_SHADOW 0
#endif
#ifndef AREA_SPREAD
#define AREA_SPREAD 0          // 1: an area light's spread below 180 degrees
#endif
#if !SOFT_SHADOW
float soft_spot_falloff(vec3 q) { return spot_falloff(q); }
float area_emission(vec3 q, float r) { return max(dot(q / max(r, 1e-30), u_emit_axis), 0.0) / (r * r); }
#else
uniform vec3 u_area_u;         // face space: an area light's half sides (an ellipse: the rectangle
uniform vec3 u_area_v;         // of its area), as vectors
uniform vec2 u_area_spread;    // AREA_SPREAD 1: tan of half its spread and Cycles' normalisation
                               // 1 / (tan h - h)

// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom and Strackee).
float triangle_solid_angle(vec3 a, vec3 b, vec3 c) {
    float la = length(a), lb = length(b), lc = length(c);
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(abs(dot(a, cross(b, c))), den);
}

uniform vec2 u_soft_extent;
uniform int u_soft_round;
uniform float u_soft_near;     // the nearest shadow caster's distance from the face's origin, metres
uniform float u_soft_seed;     // differs per antialiasing sample
vec3 g_soft_normal = vec3(0.0);    // face space: a lit surface's normal (its receiver plane), else 0
vec2 g_soft_rnd;                   // the pixel's last pair of numbers (soft_start, soft_random)
vec2 g_soft_turn;                  // cos, sin of 2 pi g_soft_rnd.y, kept by rotation (no trig a call)
vec2 g_tap_turn;                   // cos, sin of the next tap's angle (light_point)
const vec2 SOFT_STEP = vec2(0.7548777, 0.5698403);     // the R2 sequence's step

// Taps per call: one for a point of the medium (its view march and the antialiasing samples
// average them), ``surface`` for a surface (one call per pixel and sample).
int soft_taps(int surface) { return dot(g_soft_normal, g_soft_normal) > 0.0 ? surface : 1; }

// The pixel's first numbers: a hash of the pixel and the sample (called once, first thing).
void soft_start() {
    uvec3 v = uvec3(uvec2(gl_FragCoord.xy), uint(u_soft_seed * 65536.0) * 977u);
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z; v.y += v.z * v.x;
    g_soft_rnd = vec2(v.xy & 0xffffffu) / 16777216.0;
    g_soft_turn = vec2(cos(2.0 * PI * g_soft_rnd.y), sin(2.0 * PI * g_soft_rnd.y));
}

// Two numbers in [0, 1), the next of the R2 sequence from the pixel's start, so that successive
// calls along a view ray are well spread.
vec2 soft_random() {
    g_soft_rnd = fract(g_soft_rnd + SOFT_STEP);
    const vec2 turn = vec2(cos(2.0 * PI * SOFT_STEP.y), sin(2.0 * PI * SOFT_STEP.y));
    g_soft_turn = vec2(g_soft_turn.x * turn.x - g_soft_turn.y * turn.y,
                       g_soft_turn.y * turn.x + g_soft_turn.x * turn.y);
    g_tap_turn = g_soft_turn;
    return g_soft_rnd;
}

// Tap k of n over the light's shape (unit square or disk), a stratified set turned by ``rnd``, the
// last numbers soft_random gave; a call's taps are taken in order, k = 0, 1, ... (their angle's
// cos, sin kept by rotation: no trig a tap).
const float TAP_STEP = 0.618034;
vec2 light_point(int k, int n, vec2 rnd) {
    float u = fract((float(k) + rnd.x) / float(n));
    float v = fract(float(k) * TAP_STEP + rnd.y);
    vec2 cs = g_tap_turn;
    const vec2 turn = vec2(cos(2.0 * PI * TAP_STEP), sin(2.0 * PI * TAP_STEP));
    g_tap_turn = vec2(cs.x * turn.x - cs.y * turn.y, cs.y * turn.x + cs.x * turn.y);
    return u_soft_round == 1 ? sqrt(u) * cs : 2.0 * vec2(u, v) - 1.0;
}

// Map coordinates per unit of (light point in units of the extent) x spread, at q.
vec2 soft_uv_scale(vec3 q, float r, vec4 rect_half) {
    if (u_face_ortho == 1) return u_soft_extent * 0.5 / rect_half.zw;
    return u_soft_extent * 0.5 / (u_tan_half * max(-q.z / max(r, 1e-30), 1e-3));
}

// The spread of a point at distance z seen past toward a receiver at r (see the top).
float soft_spread(float z, float r) {
    return u_face_ortho == 1 ? r - z : 1.0 / max(z, 1e-6) - 1.0 / r;
}

// The depth (distance / far) the receiver has along the face's ray through ``uv``: r, or where a
// lit surface's plane (g_soft_normal through q) meets that ray, so that a tilted surface does not
// shadow itself.
float receiver_depth(vec3 q, float r, vec2 uv) {
    if (dot(g_soft_normal, g_soft_normal) == 0.0) return r;
    vec2 xy = (2.0 * uv - 1.0);
    if (u_face_ortho == 1) {
        vec3 o = vec3(u_shadow_rect.xy + xy * u_shadow_rect.zw, 0.0);
        float c = -g_soft_normal.z;
        return abs(c) < 1e-4 ? r : dot(g_soft_normal, q - o) / c;
    }
    vec3 dir = normalize(vec3(xy * u_tan_half, -1.0));
    float c = dot(g_soft_normal, dir);
    float t = abs(c) < 1e-4 ? r : dot(g_soft_normal, q) / c;
    return t > 0.0 ? t : r;
}

// Fraction of the light's shape the solids leave visible from q (distance r), the shadow map read
// at ``uv``; ``bias`` metres.
float soft_visibility(vec3 q, vec2 uv, float r, float bias) {
    vec4 rect = u_face_ortho == 1 ? u_shadow_rect : vec4(0.0, 0.0, u_tan_half);
    vec2 scale = soft_uv_scale(q, r, rect);
    float reach = soft_spread(u_face_ortho == 1 ? 0.0 : u_soft_near, r);
    vec2 rnd = soft_random();
    float spread = 0.0;
    float blockers = 0.0;
    int n = soft_taps(8);          // blocker-search taps, then as many percentage-closer taps
    for (int k = 0; k < n; ++k) {
        vec2 e = light_point(k, n, rnd);
        vec2 at = uv + e * scale * reach;
        float z = texture(u_shadow, at).r;
        float s = soft_spread(z, receiver_depth(q, r, at) - bias);
        // A solid closer than the receiver whose shadow ray comes from a point of the light.
        if (s > 0.0 && s < 1e29) {
            vec2 from = e * reach / s;
            bool inside = u_soft_round == 1 ? dot(from, from) <= 1.0
                                            : all(lessThanEqual(abs(from), vec2(1.0)));
            if (inside) {
                spread += s;
                blockers += 1.0;
            }
        }
    }
    // No blocker found: the filter's taps all fall on uv (the sharp test). One path either way
    // (llvmpipe runs both sides of a branch).
    spread = blockers > 0.0 ? spread / blockers : 0.0;
    rnd = soft_random();
    float v = 0.0;
    for (int k = 0; k < n; ++k) {
        vec2 at = uv + light_point(k, n, rnd) * scale * spread;
        v += texture(u_shadow_depth, vec3(at, (receiver_depth(q, r, at) - bias) / u_shadow_far));
    }
    return v / float(n);
}

// The spot cone's falloff at q seen from points of the light's shape (their mean).
float soft_spot_falloff(vec3 q) {
    vec2 rnd = soft_random();
    int n = soft_taps(4);
    float f = 0.0;
    for (int k = 0; k < n; ++k) f += spot_falloff(q - vec3(light_point(k, n, rnd) * u_soft_extent, 0.0));
    return f / float(n);
}

// An area light's emission profile at q: its radiance P / (pi A) over the solid angle it fills
// (seen from q, in front of it), per unit of the face's intensity P / pi: the solid angle over the
// area. Far from the light it is the point's cos(theta) / r^2. A spread below 180 degrees: Cycles'
// soft-box grid, max(tan h - tan a, 0) / (tan h - h) at the angle a from the axis, read from points
// of the light (its cone's edge is soft, as each point of the light has its own).
float area_emission(vec3 q, float r) {
    if (dot(q, u_emit_axis) <= 0.0) return 0.0;
    vec3 c0 = -q - u_area_u - u_area_v, c1 = -q + u_area_u - u_area_v;
    vec3 c2 = -q + u_area_u + u_area_v, c3 = -q - u_area_u + u_area_v;
    float area = 4.0 * length(cross(u_area_u, u_area_v));
    float e = (triangle_solid_angle(c0, c1, c2) + triangle_solid_angle(c0, c2, c3)) / max(area, 1e-30);
#if AREA_SPREAD
    vec2 rnd = soft_random();
    int n = soft_taps(8);
    float grid = 0.0;
    for (int k = 0; k < n; ++k) {
        vec2 at = light_point(k, n, rnd);
        vec3 d = q - at.x * u_area_u - at.y * u_area_v;
        float c = dot(d, u_emit_axis) / max(length(d), 1e-30);
        grid += max((u_area_spread.x - sqrt(max(1.0 - c * c, 0.0)) / max(c, 1e-6)) * u_area_spread.y, 0.0);
    }
    e *= grid / float(n);
#endif
    return e;
}
#endif
