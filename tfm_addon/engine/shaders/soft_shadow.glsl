// Soft shadows from a light's size (SOFT_SHADOW 1; light.soft_extent): the light seen as a shape
// across its face, u_soft_extent half-widths (perspective faces: metres in the face's plane; a sun:
// the tangent of half its angle), a rectangle or (u_soft_round) an ellipse. Included by common.glsl.
//
// A light point e and a receiver at distance r: the ray between them crosses the face's centre ray
// through map coordinates uv + e * spread * uv_per_unit, where spread = 1/z - 1/r (perspective,
// z the distance of what it crosses there; divided by the receiver's cos to the face axis) or
// r - z (a sun).
//
// Each point lit (light_reaching) draws one light sample: a point e of the light's shape from the
// R2 sequence, started per pixel and sample by a hash. A point of the medium reads everything
// through that one point, as Cycles reads the light from the one light point it samples (its view
// march and the antialiasing samples average them): the spot's cone from e (its edge is soft);
// the solids' shadow along the ray from e, a blocker read where it crosses the nearest caster's
// depth, then the shadow test where it crosses that blocker's; the medium's transmittance, the
// map read where it crosses the middle of the medium (transmittance.glsl). A lit surface (one
// call per pixel and sample) takes stratified taps over the shape instead: percentage-closer soft
// shadowing (8 blocker-search taps over the footprint of the nearest caster, then 8 filter taps
// over the shape scaled by the blockers' mean spread, or one where no blocker was found or the
// penumbra is under half a texel), 4 taps of the cone, 4 of the transmittance. The surfaces' taps
// run in loops of no turn for a point of the medium: llvmpipe, which runs both sides of a branch,
// skips a loop that no pixel of its group enters. An area light's emission: the solid angle its
// rectangle fills (area_emission), with its spread.
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

// Solid angle of the quadrilateral (a, b, c, d) seen from the origin, its triangles (a, b, c) and
// (a, c, d) (Van Oosterom and Strackee: tan(omega / 2) = N / D each), their half angles added as
// the arguments of D + iN multiplied (one atan; their sum is below pi for a light seen in front).
float quad_solid_angle(vec3 a, vec3 b, vec3 c, vec3 d) {
    float la = length(a), lb = length(b), lc = length(c), ld = length(d);
    float ac = dot(a, c);
    float n1 = abs(dot(a, cross(b, c))), d1 = la * lb * lc + dot(a, b) * lc + ac * lb + dot(b, c) * la;
    float n2 = abs(dot(a, cross(c, d))), d2 = la * lc * ld + ac * ld + dot(a, d) * lc + dot(c, d) * la;
    return 2.0 * atan(n1 * d2 + n2 * d1, d1 * d2 - n1 * n2);
}

uniform vec2 u_soft_extent;
uniform int u_soft_round;
uniform float u_soft_near;     // the nearest shadow caster's distance from the face's origin, metres
uniform float u_soft_seed;     // differs per antialiasing sample
vec3 g_soft_normal = vec3(0.0);    // face space: a lit surface's normal (its receiver plane), else 0
vec2 g_soft_rnd;                   // the light sample's pair of numbers (soft_start, soft_next)
vec2 g_soft_turn;                  // cos, sin of 2 pi g_soft_rnd.y, kept by rotation (no trig a call)
vec2 g_tap_turn;                   // cos, sin of the next tap's angle (light_point)
const vec2 SOFT_STEP = vec2(0.7548777, 0.5698403);     // the R2 sequence's step

vec2 g_soft_e;                     // the light sample's point of the light's shape (soft_next)
float g_soft_blocker = -1.0;        // the depth of the last blocker a point of the medium found, metres

// Taps of a lit surface: ``surface``; none for a point of the medium (it reads g_soft_e alone).
int surface_taps(int surface) { return dot(g_soft_normal, g_soft_normal) > 0.0 ? surface : 0; }

// The pixel's first numbers: a hash of the pixel and the sample (called once, first thing).
void soft_start() {
    uvec3 v = uvec3(uvec2(gl_FragCoord.xy), uint(u_soft_seed * 65536.0) * 977u);
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z; v.y += v.z * v.x;
    g_soft_rnd = vec2(v.xy & 0xffffffu) / 16777216.0;
    g_soft_turn = vec2(cos(2.0 * PI * g_soft_rnd.y), sin(2.0 * PI * g_soft_rnd.y));
    g_soft_blocker = u_soft_near;
}

// The next light sample (light_reaching calls it once per point lit): two numbers in [0, 1), the
// next of the R2 sequence from the pixel's start, so that successive points along a view ray are
// well spread.
void soft_next() {
    g_soft_rnd = fract(g_soft_rnd + SOFT_STEP);
    const vec2 turn = vec2(cos(2.0 * PI * SOFT_STEP.y), sin(2.0 * PI * SOFT_STEP.y));
    g_soft_turn = vec2(g_soft_turn.x * turn.x - g_soft_turn.y * turn.y,
                       g_soft_turn.y * turn.x + g_soft_turn.x * turn.y);
    g_soft_e = u_soft_round == 1 ? sqrt(g_soft_rnd.x) * g_soft_turn : 2.0 * g_soft_rnd - 1.0;
}

// A surface's taps from the light sample's numbers: every read of the light's shape for one
// surface point (the cone, the solids, the media) takes the same points of it.
vec2 soft_taps_start() {
    g_tap_turn = g_soft_turn;
    return g_soft_rnd;
}

// Tap k of n over the light's shape (unit square or disk), a stratified set turned by ``rnd``, the
// numbers soft_taps_start gave; a call's taps are taken in order, k = 0, 1, ... (their angle's
// cos, sin kept by rotation: no trig a tap).
const float TAP_STEP = 0.618034;
vec2 square_point(int k, int n, vec2 rnd) {      // in [0, 1)^2; tap 0 is ``rnd``
    return vec2(fract(rnd.x + float(k) / float(n)), fract(float(k) * TAP_STEP + rnd.y));
}
vec2 light_point(int k, int n, vec2 rnd) {
    vec2 uv = square_point(k, n, rnd);
    vec2 cs = g_tap_turn;
    const vec2 turn = vec2(cos(2.0 * PI * TAP_STEP), sin(2.0 * PI * TAP_STEP));
    g_tap_turn = vec2(cs.x * turn.x - cs.y * turn.y, cs.y * turn.x + cs.x * turn.y);
    return u_soft_round == 1 ? sqrt(uv.x) * cs : 2.0 * uv - 1.0;
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
    vec2 xy = (2.0 * uv - 1.0);
    if (u_face_ortho == 1) {
        vec3 o = vec3(u_shadow_rect.xy + xy * u_shadow_rect.zw, 0.0);
        float c = -g_soft_normal.z;
        return abs(c) < 1e-4 ? r : dot(g_soft_normal, q - o) / c;
    }
    vec3 dir = vec3(xy * u_tan_half, -1.0);    // no normal (a point of the medium): c = 0
    float len = length(dir);
    float c = dot(g_soft_normal, dir);
    float t = dot(g_soft_normal, q) * len / c;
    return abs(c) < 1e-4 * len || t <= 0.0 ? r : t;
}

// Whether a caster seen at depth z from the receiver at r shadows it from a point of the light:
// closer than the receiver, its shadow ray from ``e`` (a tap reaching ``reach``) within the shape.
float blocker_spread(float z, float r, vec2 e, float reach) {
    float s = soft_spread(z, r);
    vec2 from = e * reach / s;
    bool inside = u_soft_round == 1 ? dot(from, from) <= 1.0 : all(lessThanEqual(abs(from), vec2(1.0)));
    return s > 0.0 && s < 1e29 && inside ? s : 0.0;
}

// Fraction of the light's shape the solids leave visible from q (distance r), the shadow map read
// at ``uv``; ``bias`` metres.
float soft_visibility(vec3 q, vec2 uv, float r, float bias) {
    vec4 rect = u_face_ortho == 1 ? u_shadow_rect : vec4(0.0, 0.0, u_tan_half);
    vec2 scale = soft_uv_scale(q, r, rect);
    float reach = soft_spread(u_soft_near, r);
    // A point of the medium: the map where the ray from g_soft_e crosses the depth of the last
    // blocker found along the view ray (none yet: the nearest caster's), one read; what it finds
    // closer than the point shadows it and is the next point's blocker.
    float z = texture(u_shadow, uv + g_soft_e * scale * max(soft_spread(g_soft_blocker, r - bias), 0.0)).r;
    bool shadowed = z < r - bias;
    g_soft_blocker = shadowed ? z : g_soft_blocker;
    float v = shadowed ? 0.0 : 1.0;
    // A surface: the blocker search, then the filter (its receiver's plane at each tap).
    vec2 rnd = soft_taps_start();
    float spread = 0.0;
    float blockers = 0.0;
    int n = surface_taps(8);
    for (int k = 0; k < n; ++k) {
        vec2 p = light_point(k, n, rnd);
        vec2 at = uv + p * scale * reach;
        float b = blocker_spread(texture(u_shadow, at).r, receiver_depth(q, r, at) - bias, p, reach);
        spread += b;
        blockers += b > 0.0 ? 1.0 : 0.0;
    }
    spread = blockers > 0.0 ? spread / blockers : 0.0;
    // The filter: a tap per shadow-map texel across the penumbra, 1 to 8 (one where no blocker was
    // found or the penumbra is under a texel: the sharp test).
    int m = min(int(ceil(2.0 * spread * max(scale.x, scale.y) * u_map_res)), 8);
    m = n > 0 ? max(m, 1) : 0;
    rnd = soft_taps_start();
    float sum = 0.0;
    for (int k = 0; k < m; ++k) {
        vec2 at = uv + light_point(k, m, rnd) * scale * spread;
        sum += texture(u_shadow_depth, vec3(at, (receiver_depth(q, r, at) - bias) / u_shadow_far));
    }
    return m > 0 ? sum / float(m) : v;
}

// The spot cone's falloff at q seen from points of the light's shape (their mean).
float soft_spot_falloff(vec3 q) {
    float f = spot_falloff(q - vec3(g_soft_e * u_soft_extent, 0.0));
    vec2 rnd = soft_taps_start();
    int n = surface_taps(4);
    float sum = 0.0;
    for (int k = 0; k < n; ++k) sum += spot_falloff(q - vec3(light_point(k, n, rnd) * u_soft_extent, 0.0));
    return n > 0 ? sum / float(n) : f;
}

#if AREA_SPREAD
// What the point ``at`` of an area light (in half sides) sends to q, per unit of area and of the
// face's intensity P / pi: Cycles' soft-box grid, max(tan h - tan a, 0) / (tan h - h) at the angle
// a from the light's axis, times the solid angle per unit of the light's area, cos a / d^2.
float spread_emitted(vec3 q, vec2 at) {
    vec3 d = q - at.x * u_area_u - at.y * u_area_v;
    float d2 = max(dot(d, d), 1e-30);
    float c = dot(d, u_emit_axis) * inversesqrt(d2);
    float tan_a = sqrt(max(1.0 - c * c, 0.0)) / max(c, 1e-6);
    return c > 0.0 ? max((u_area_spread.x - tan_a) * u_area_spread.y, 0.0) * c / d2 : 0.0;
}

// An area light whose spread is below 180 degrees: spread_emitted's mean over the light (the
// rectangle of its area for an ellipse), read where it is not 0: the part of the rectangle within
// dist tan h of q's foot on its plane (Cycles samples the same part, area_light_spread_clamp_light).
// A point of the medium reads it through its light sample's point, which its shadows then read too
// (the same point of the light, as in Cycles); a surface through 8 stratified taps, and its
// transmittance through 4 of them weighted by what each sends (spread_tap).
vec2 g_spread_lo;                  // the part's lower corner and size, in half sides
vec2 g_spread_size;
float area_spread_emission(vec3 q) {
    vec2 len2 = vec2(dot(u_area_u, u_area_u), dot(u_area_v, u_area_v));
    vec2 foot = vec2(dot(q, u_area_u), dot(q, u_area_v)) / len2;
    vec2 reach = dot(q, u_emit_axis) * u_area_spread.x * inversesqrt(len2);
    g_spread_lo = max(foot - reach, vec2(-1.0));
    g_spread_size = max(min(foot + reach, vec2(1.0)) - g_spread_lo, vec2(0.0));
    vec2 at = g_spread_lo + g_spread_size * g_soft_rnd;
    g_soft_e = (at.x * u_area_u.xy + at.y * u_area_v.xy) / u_soft_extent;
    float e = spread_emitted(q, at);
    vec2 rnd = soft_taps_start();
    int n = surface_taps(8);
    float sum = 0.0;
    for (int k = 0; k < n; ++k) sum += spread_emitted(q, g_spread_lo + g_spread_size * square_point(k, n, rnd));
    return 0.25 * g_spread_size.x * g_spread_size.y * (n > 0 ? sum / float(n) : e);
}

// A surface's tap k of n over the part of an area light that lights q: its point of the light's
// shape across the face (as light_point), and what it sends to q (its weight).
vec2 spread_tap(vec3 q, int k, int n, vec2 rnd, out float weight) {
    vec2 at = g_spread_lo + g_spread_size * square_point(k, n, rnd);
    weight = spread_emitted(q, at);
    return (at.x * u_area_u.xy + at.y * u_area_v.xy) / u_soft_extent;
}
#endif

// An area light's emission profile at q: its radiance P / (pi A) over the solid angle it fills
// (seen from q, in front of it), per unit of the face's intensity P / pi: the solid angle over the
// area. Far from the light it is the point's cos(theta) / r^2.
float area_emission(vec3 q, float r) {
    if (dot(q, u_emit_axis) <= 0.0) return 0.0;
#if AREA_SPREAD
    return area_spread_emission(q);
#else
    // Beyond 8 half diagonals h of the light: the point's cos / r^2 with its second-order term
    // over the rectangle (within 4e-4); nearer, the solid angle (a loop that a group of pixels all
    // far from the light skips).
    vec2 s = vec2(dot(q, u_area_u), dot(q, u_area_v));
    float h2 = dot(u_area_u, u_area_u) + dot(u_area_v, u_area_v);
    float r2 = r * r;
    float e = dot(q, u_emit_axis) / (r2 * r) * (1.0 + (15.0 * dot(s, s) / r2 - 3.0 * h2) / (6.0 * r2));
    for (int i = 0; i < (r2 < 64.0 * h2 ? 1 : 0); ++i) {
        vec3 c0 = -q - u_area_u - u_area_v, c1 = -q + u_area_u - u_area_v;
        vec3 c2 = -q + u_area_u + u_area_v, c3 = -q - u_area_u + u_area_v;
        e = quad_solid_angle(c0, c1, c2, c3) / max(4.0 * length(cross(u_area_u, u_area_v)), 1e-30);
    }
    return e;
#endif
}
#endif
