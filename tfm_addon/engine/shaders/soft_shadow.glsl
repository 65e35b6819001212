// Soft shadows from a light's size (SOFT_SHADOW 1; light.soft_extent): the light seen as a shape
// across its face, u_soft_extent half-widths (perspective faces: metres in the face's plane; a sun:
// the tangent of half its angle), a rectangle or (SOFT_ROUND) an ellipse. Included by common.glsl.
//
// A light point e and a receiver at distance r: the ray between them crosses the face's centre ray
// through map coordinates uv + e * spread * uv_per_unit, where spread = 1/z - 1/r (perspective,
// z the distance of what it crosses there; divided by the receiver's cos to the face axis) or
// r - z (a sun).
//
// Each point lit (light_reaching) draws a light sample, a point e of the light's shape from the R2
// sequence started per pixel and sample by a hash, and reads everything through it, as Cycles
// reads the light from the one light point it samples: the spot's cone from e (its edge is soft);
// the solids' shadow along the ray from e, the shadow map read where it crosses the depth of the
// last blocker found (the nearest caster's before any); the medium's transmittance where it
// crosses the middle of the medium (transmittance.glsl); a spread area light's emission from e. A
// point of the medium takes one light sample (its view march and the antialiasing samples average
// them), in code without loops or branches: llvmpipe runs both sides of a branch, and a loop's body
// at least once, so taps for surfaces there would cost every sample of the march. A lit surface
// takes SOFT_SURFACE_SAMPLES once per pixel, before its light is read (soft_surface,
// transmittance.glsl).
#ifndef SOFT_SHADOW
#define SOFT_SHADOW 0
#endif
#ifndef SOFT_SURFACE_SAMPLES
#define SOFT_SURFACE_SAMPLES 6    // light samples of a lit surface (of its transmittance: a third)
#endif
#ifndef SOFT_ROUND
#define SOFT_ROUND 0           // 1: the light's shape is round (an ellipse), else a rectangle
#endif
#ifndef AREA_FAR
#define AREA_FAR 0             // 1: everything an area light's face lights is far from it
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
uniform float u_soft_near;     // the nearest caster's distance (a sun: depth) from the face's origin, m
uniform float u_soft_seed;     // differs per antialiasing sample
vec3 g_soft_normal = vec3(0.0);    // face space: a lit surface's normal (its receiver plane), else 0
vec2 g_soft_rnd;                   // the light sample's pair of numbers (soft_start, soft_next)
vec2 g_soft_turn;                  // cos, sin of 2 pi g_soft_rnd.y, kept by rotation (no trig a call)
vec2 g_soft_e;                     // the light sample's point of the light's shape
float g_soft_blocker;              // the depth of the last blocker a light sample found, metres
float g_surface_visibility = -1.0; // a lit surface's means over its light samples (soft_surface,
float g_surface_shape = -1.0;      // transmittance.glsl): the solids' visibility, the spot cone or
                                   // the spread area light's emission; -1 for a point of the medium
const vec2 SOFT_STEP = vec2(0.7548777, 0.5698403);     // the R2 sequence's step

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

// The next light sample (light_reaching, once per point lit): the next of the R2 sequence from the
// pixel's start, so that successive samples along a view ray or on a surface are well spread, and
// its point of the shape (a disk's angle kept by rotation: no trig a sample).
void soft_next() {
    g_soft_rnd = fract(g_soft_rnd + SOFT_STEP);
    const vec2 turn = vec2(cos(2.0 * PI * SOFT_STEP.y), sin(2.0 * PI * SOFT_STEP.y));
    g_soft_turn = vec2(g_soft_turn.x * turn.x - g_soft_turn.y * turn.y,
                       g_soft_turn.y * turn.x + g_soft_turn.x * turn.y);
#if SOFT_ROUND
    g_soft_e = sqrt(g_soft_rnd.x) * g_soft_turn;
#else
    g_soft_e = 2.0 * g_soft_rnd - 1.0;
#endif
}

// Map coordinates per unit of (light point in units of the extent) x spread, at q.
vec2 soft_uv_scale(vec3 q, float r, vec4 rect_half) {
    if (u_face_ortho == 1) return u_soft_extent * 0.5 / rect_half.zw;
    return (u_soft_extent * 0.5 / u_tan_half) * (r / max(-q.z, 1e-3 * r));
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

// The light sample's map coordinates for q (distance r, centre ``uv``): where the ray from its point
// crosses the depth of the last blocker found.
vec2 soft_tap(vec3 q, vec2 uv, float r) {
    vec4 rect = u_face_ortho == 1 ? u_shadow_rect : vec4(0.0, 0.0, u_tan_half);
    return uv + g_soft_e * soft_uv_scale(q, r, rect) * max(soft_spread(g_soft_blocker, r), 0.0);
}

// Whether the shadow map holds a caster closer than ``depth`` at ``at`` (past its edge, another
// face's or no caster's: none); one found is the next sample's blocker.
bool soft_shadowed(vec2 at, float depth) {
    float z = texture(u_shadow, at).r;
    bool shadowed = z < depth && all(lessThan(abs(at - 0.5), vec2(0.5)));
    g_soft_blocker = shadowed ? z : g_soft_blocker;
    return shadowed;
}

// Fraction of the light the solids leave visible from q (distance r; ``uv`` its shadow-map
// coordinates, ``bias`` metres): for a point of the medium, its light sample's; for a lit
// surface, the mean of its samples (soft_surface).
float soft_visibility(vec3 q, vec2 uv, float r, float bias) {
    bool shadowed = soft_shadowed(soft_tap(q, uv, r), r - bias);
    return g_surface_visibility >= 0.0 ? g_surface_visibility : (shadowed ? 0.0 : 1.0);
}

// A lit surface's light sample: compared with the depth of its plane along the tap's ray.
float surface_visibility(vec3 q, float r) {
    vec2 uv = shadow_uv(q);
    if (u_has_shadow == 0 || (u_face_ortho == 1 && any(greaterThan(abs(uv - 0.5), vec2(0.5))))) return 1.0;
    vec2 at = soft_tap(q, uv, r);
    return soft_shadowed(at, receiver_depth(q, r, at) - shadow_bias(r)) ? 0.0 : 1.0;
}

// Whether a point of the light's shape may light q through a spot's cone: q within the cone
// widened by the angle the shape's extent subtends from it (in the cone's scaled space).
bool spot_reaches(vec3 q) {
    vec3 s = vec3(q.xy / u_cone_scale, q.z);
    float d = length(s);
    float sin_w = min(max(u_soft_extent.x, u_soft_extent.y) / (min(u_cone_scale.x, u_cone_scale.y) * d), 1.0);
    float sin_h = sqrt(max(1.0 - u_cos_half * u_cos_half, 0.0));
    return -s.z > d * (u_cos_half * sqrt(1.0 - sin_w * sin_w) - sin_h * sin_w);
}

// The spot cone's falloff at q seen from the light sample's point.
float soft_spot_falloff(vec3 q) {
    return g_surface_shape >= 0.0 ? g_surface_shape : spot_falloff(q - vec3(g_soft_e * u_soft_extent, 0.0));
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
// dist tan h of q's foot on its plane (Cycles samples the same part, area_light_spread_clamp_light),
// through the light sample's point there, which its shadows and transmittance then read too.
float area_spread_emission(vec3 q) {
    vec2 len2 = vec2(dot(u_area_u, u_area_u), dot(u_area_v, u_area_v));
    vec2 foot = vec2(dot(q, u_area_u), dot(q, u_area_v)) / len2;
    vec2 reach = dot(q, u_emit_axis) * u_area_spread.x * inversesqrt(len2);
    vec2 lo = max(foot - reach, vec2(-1.0));
    vec2 size = max(min(foot + reach, vec2(1.0)) - lo, vec2(0.0));
    vec2 at = lo + size * g_soft_rnd;
    g_soft_e = (at.x * u_area_u.xy + at.y * u_area_v.xy) / u_soft_extent;
    return g_surface_shape >= 0.0 ? g_surface_shape : 0.25 * size.x * size.y * spread_emitted(q, at);
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
#if AREA_FAR
    // Everything the face lights beyond 3.5 half diagonals of the light (light.area_emission_far):
    // the point's cos / r^2 with the second- and fourth-order terms of its mean over the rectangle
    // (the Gegenbauer series of 1 / |q - x|^3, averaged over x), within 0.2 %.
    float a2 = dot(u_area_u, u_area_u), b2 = dot(u_area_v, u_area_v);
    float ua = dot(q, u_area_u), vb = dot(q, u_area_v);
    float A = ua * ua, B = vb * vb;
    float i2 = 1.0 / (r * r);
    float t2 = (2.5 * (A + B) * i2 - 0.5 * (a2 + b2)) * i2;
    float t4 = 1.875 * i2 * i2 * ((4.2 * (A * A + B * B) + 14.0 * A * B) * i2 * i2
                                  - (A * (2.8 * a2 + 14.0 / 9.0 * b2) + B * (14.0 / 9.0 * a2 + 2.8 * b2)) * i2
                                  + 0.2 * (a2 * a2 + b2 * b2) + 2.0 / 9.0 * a2 * b2);
    return dot(q, u_emit_axis) * i2 / r * (1.0 + t2 + t4);
#else
    vec3 c0 = -q - u_area_u - u_area_v, c1 = -q + u_area_u - u_area_v;
    vec3 c2 = -q + u_area_u + u_area_v, c3 = -q - u_area_u + u_area_v;
    return quad_solid_angle(c0, c1, c2, c3) / max(4.0 * length(cross(u_area_u, u_area_v)), 1e-30);
#endif
#endif
}
#endif
