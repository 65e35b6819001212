// Shared by the fragment shaders: the media's bounds and densities, the light face, the phase.
const float PI = 3.14159265358979;
const float NO_HIT = 1e30;

// GREY_EXTINCTION 1 (passes/scattering.grey_extinction): every marched medium's extinction, and
// so every transmittance, is the same in the three channels: one channel's exponential serves
// them all (and the compiler drops the other two channels' arithmetic).
#ifndef GREY_EXTINCTION
#define GREY_EXTINCTION 0
#endif
#if GREY_EXTINCTION
#define EXP_RGB(v) vec3(exp((v).x))
#define EXP2_RGB(v) vec3(exp2((v).x))
#else
#define EXP_RGB(v) exp(v)
#define EXP2_RGB(v) exp2(v)
#endif

// ---- a view step of constant extinction sigma_t and length dt ----
// The integral of the view transmittance exp(-sigma_t s) over the step, s in [0, dt] from its
// start, given e = exp(-sigma_t dt): (1 - e) / sigma_t, dt where sigma_t dt is small. Each source
// term of the step times it, times the transmittance before the step, is the step's exact share.
vec3 step_integral(vec3 sigma_t, float dt, vec3 e) {
    vec3 x = sigma_t * dt;
    return mix((1.0 - e) / max(sigma_t, vec3(1e-30)), dt * (1.0 - x * (0.5 - x / 6.0)),
               lessThan(x, vec3(1e-2)));
}

// Where in such a step the camera sees on average, as a fraction of dt: the mean of s / dt weighted
// by exp(-x s / dt), x = sigma_t dt: 1/2 where x is small, 1/x where it is large.
float seen_fraction(float x) {
    return x < 0.5 ? 0.5 - x / 12.0 + x * x * x / 720.0 : 1.0 / x - 1.0 / (exp(x) - 1.0);
}

// ---- the medium: an oriented box (a grid's index box, or the [-1, 1] cube) ----
uniform mat4 u_world_to_box;
uniform vec3 u_box_lo;
uniform vec3 u_box_hi;
uniform sampler3D u_density;   // padded by one zero voxel on every side
uniform vec3 u_grid_size;      // padded texture size, voxels
uniform float u_density_scale; // the texture holds density / u_density_scale

// Ray (o, d) against the medium's box: (t_in, t_out) in units of d; t_in >= t_out when missed.
vec2 box_interval(vec3 o, vec3 d) {
    vec3 ob = (u_world_to_box * vec4(o, 1.0)).xyz;
    vec3 db = (u_world_to_box * vec4(d, 0.0)).xyz;
    db = mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
    vec3 t0 = (u_box_lo - ob) / db;
    vec3 t1 = (u_box_hi - ob) / db;
    vec3 tmin = min(t0, t1);
    vec3 tmax = max(t0, t1);
    return vec2(max(max(tmin.x, tmin.y), tmin.z), min(min(tmax.x, tmax.y), tmax.z));
}

// The stored density of grid slot 0 (u_density) at texture coordinates ``tc`` of its padded
// lattice, level ``lod``. SPARSE_GRID 1 (engine/sparse_grid.py): u_density is an atlas of 9^3
// bricks, one per non-empty 8^3 cell of the lattice, found through u_brick_index; a brick holds
// every voxel trilinear reads inside its cell, so the hardware filters within it; a cell without
// one is 0. It has no level 1: every level reads level 0.
#ifndef SPARSE_GRID
#define SPARSE_GRID 0
#endif
#if SPARSE_GRID
uniform usampler3D u_brick_index;  // per cell: its brick's slot (xyz) and 1 in a, or 0
uniform vec3 u_sparse_size;        // the padded lattice's size, voxels
uniform vec3 u_atlas_size;         // the atlas's size, voxels
float sparse_density(vec3 tc) {
    vec3 p = tc * u_sparse_size - 0.5;       // padded voxel position (centres at integers)
    ivec3 cell = ivec3(floor(p / 8.0));
    if (any(lessThan(cell, ivec3(0))) || any(greaterThanEqual(cell, textureSize(u_brick_index, 0))))
        return 0.0;
    uvec4 slot = texelFetch(u_brick_index, cell, 0);
    if (slot.a == 0u) return 0.0;
    return textureLod(u_density, (vec3(slot.xyz) * 9.0 + (p - vec3(cell) * 8.0) + 0.5) / u_atlas_size, 0.0).r;
}
#endif
float grid0(vec3 tc, float lod) {
#if SPARSE_GRID
    return sparse_density(tc);
#else
    return textureLod(u_density, tc, lod).r;
#endif
}

// Density at a point given in box (grid index) space: trilinear between voxel centres.
float density_at_index(vec3 idx) {
    return grid0((idx + 1.5) / u_grid_size, 0.0) * u_density_scale;
}

// Empty-space skipping: u_occupancy's R is 1 where a cell of u_occupancy_block^3 padded voxels may
// hold non-zero density (passes/bindings.occupancy), its G (an emitting medium's, passes/emission)
// where the cell may emit. The ray parameter where the ray ob + db t (box space) leaves the empty
// cell holding its point at t, or t when that cell is not empty.
uniform sampler3D u_occupancy;
uniform float u_occupancy_block;
float skip_empty(vec3 ob, vec3 db, float t) {
    ivec3 cell = clamp(ivec3(floor((ob + db * t + 1.0) / u_occupancy_block)), ivec3(0),
                       textureSize(u_occupancy, 0) - 1);
    if (any(greaterThan(texelFetch(u_occupancy, cell, 0).rg, vec2(0.0)))) return t;
    db = mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
    vec3 tb = ((vec3(cell) + step(0.0, db)) * u_occupancy_block - 1.0 - ob) / db;
    return max(t, min(min(tb.x, tb.y), tb.z));
}

// Density at a world point.
float density_at(vec3 p) {
    return density_at_index((u_world_to_box * vec4(p, 1.0)).xyz);
}

#ifdef N_MEDIA
// ---- several media (MEDIUM 3): N_MEDIA boxes, each a grid slot (or -1: density 1 in its box) ----
const int MAX_MEDIA = 8;
uniform mat4 u_med_to_box[MAX_MEDIA];     // world to the medium's index (or [-1, 1]) space
uniform vec3 u_med_lo[MAX_MEDIA];
uniform vec3 u_med_hi[MAX_MEDIA];
uniform vec3 u_med_sigma_t[MAX_MEDIA];    // 1/m per unit density
uniform vec3 u_med_sigma_s[MAX_MEDIA];
uniform float u_med_g[MAX_MEDIA];
uniform float u_med_weight[MAX_MEDIA];    // the medium's weight in the lights' TFMs
uniform vec3 u_grid_sizes[4];             // padded texture sizes of the grid slots
uniform float u_grid_scales[4];           // each texture holds density / its scale
#if N_GRIDS > 1
uniform sampler3D u_density1;
#endif
#if N_GRIDS > 2
uniform sampler3D u_density2;
#endif
#if N_GRIDS > 3
uniform sampler3D u_density3;
#endif

float grid_fetch(int slot, vec3 idx) {
#if N_GRIDS > 1
    if (slot == 1) return textureLod(u_density1, (idx + 1.5) / u_grid_sizes[1], 0.0).r * u_grid_scales[1];
#endif
#if N_GRIDS > 2
    if (slot == 2) return textureLod(u_density2, (idx + 1.5) / u_grid_sizes[2], 0.0).r * u_grid_scales[2];
#endif
#if N_GRIDS > 3
    if (slot == 3) return textureLod(u_density3, (idx + 1.5) / u_grid_sizes[3], 0.0).r * u_grid_scales[3];
#endif
    return grid0((idx + 1.5) / u_grid_sizes[0], 0.0) * u_grid_scales[0];
}

// Each medium's grid slot (-1: a box of density 1), fixed when the program is compiled, so that
// once the loops over the media are unrolled every fetch reads one known texture.
const int MEDIA_SLOT[MAX_MEDIA] = MEDIA_SLOTS;

// Density of medium m at a world point (0 outside its box).
float medium_density(int m, vec3 p) {
    vec3 idx = (u_med_to_box[m] * vec4(p, 1.0)).xyz;
    if (any(lessThan(idx, u_med_lo[m])) || any(greaterThan(idx, u_med_hi[m]))) return 0.0;
    return MEDIA_SLOT[m] < 0 ? 1.0 : grid_fetch(MEDIA_SLOT[m], idx);
}

// The TFM's density: the media's densities weighted as the map stores them.
float weighted_density(vec3 p) {
    float d = 0.0;
    for (int m = 0; m < N_MEDIA; ++m) d += u_med_weight[m] * medium_density(m, p);
    return d;
}

// Extinction (1/m per channel) of all media at p.
vec3 extinction_at(vec3 p) {
    vec3 s = vec3(0.0);
    for (int m = 0; m < N_MEDIA; ++m) s += u_med_sigma_t[m] * medium_density(m, p);
    return s;
}

// A ray's density where it crosses one grid medium alone (N_MEDIA 1, a grid in slot 0): texture
// coordinates linear in the ray parameter, set once per ray, so that a sample costs one fetch, not
// a matrix product and a box test (outside its non-zero bounds the grid's trilinear density is 0
// anyway, and the texture clamps to its zero padding). Otherwise the media's weighted density.
struct GridRay {
    vec3 o;
    vec3 d;
    vec3 tc0;      // texture coordinates at t = 0, and per unit t
    vec3 tcd;
    float scale;   // the texture's density scale times the weight
    float lod;     // the grid's level read: 0, or 1 (the 2x2x2 means) for a march whose steps
                   // and light-map texels are at least two voxels wide (grid_ray_lod)
};
GridRay grid_ray(vec3 o, vec3 d, float weight) {
    return GridRay(o, d, ((u_med_to_box[0] * vec4(o, 1.0)).xyz + 1.5) / u_grid_sizes[0],
                   (mat3(u_med_to_box[0]) * d) / u_grid_sizes[0], u_grid_scales[0] * weight, 0.0);
}
// The level for samples spaced ``spacing`` metres along the ray, each standing for a patch
// ``width`` metres wide across it: 1 where both span two voxels of the lone grid, else 0.
float grid_ray_lod(GridRay g, float spacing, float width) {
    float voxels = min(spacing, width) * length(g.tcd * u_grid_sizes[0]);
    return voxels >= 2.0 ? 1.0 : 0.0;
}
// The lone grid's density at o + d t times the weight given to grid_ray, or (several media, or a
// box) the media's weighted density there.
float ray_density(GridRay g, float t) {
#if N_MEDIA == 1
    if (MEDIA_SLOT[0] >= 0) return grid0(g.tc0 + g.tcd * t, g.lod) * g.scale;
#endif
    return weighted_density(g.o + g.d * t);
}

// The ray (o, d) against every medium's box: the union's (t_in, t_out); t_in >= t_out: missed.
vec2 media_interval(vec3 o, vec3 d) {
    vec2 r = vec2(1e30, -1e30);
    for (int m = 0; m < N_MEDIA; ++m) {
        vec3 ob = (u_med_to_box[m] * vec4(o, 1.0)).xyz;
        vec3 db = (u_med_to_box[m] * vec4(d, 0.0)).xyz;
        db = mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
        vec3 t0 = (u_med_lo[m] - ob) / db;
        vec3 t1 = (u_med_hi[m] - ob) / db;
        vec3 tmin = min(t0, t1);
        vec3 tmax = max(t0, t1);
        float a = max(max(tmin.x, tmin.y), tmin.z);
        float b = min(min(tmax.x, tmax.y), tmax.z);
        if (b > a) r = vec2(min(r.x, a), max(r.y, b));
    }
    return r;
}
#endif

// ---- one projection face of a light (light.py's LightFrame) ----
uniform mat4 u_world_to_light;   // rigid: the face looking along -Z (a sun: origin on its near plane)
uniform vec3 u_light_pos;        // the face's origin, world
uniform vec3 u_intensity;        // W/sr per channel (a sun: irradiance, W/m^2)
uniform float u_cos_half;        // cos of half the cone angle
uniform float u_spot_smooth;     // (1 - cos_half) * blend
uniform vec2 u_tan_half;         // half-widths of the frustum at unit distance (ortho: metres)
uniform int u_face_ortho;        // 1: orthographic face (a sun)
uniform int u_profile;           // 0 spot cone, 1 uniform, 2 cosine about u_emit_axis
uniform vec3 u_emit_axis;        // face space
uniform vec4 u_shadow_rect;      // ortho: face-space centre and half extents of the shadow map
uniform vec2 u_cone_scale;       // an elliptical cone's x, y scale (object scale x/z, y/z)
uniform float u_map_res;         // texels per side of the shadow map and TFM
uniform int u_has_shadow;
#ifndef MEDIUM_SHADOW
#define MEDIUM_SHADOW 1          // 0: no solid shadows a point of the media (light.solids_may_shadow)
#endif
uniform sampler2D u_shadow;      // distance from the light to the nearest solid, metres
uniform sampler2DShadow u_shadow_depth;   // the same as depth, distance / u_shadow_far
uniform float u_shadow_far;     // metres; the depth texture holds distance / far (linear)
uniform int u_has_gobo;
uniform sampler2D u_gobo;
// FACE_KIND 1 (the light passes, passes/scattering.face_defines): the face's kind compiled in
// (FACE_ORTHO, FACE_PROFILE, FACE_SHADOW, FACE_GOBO) in place of the uniforms above, whose every
// branch the GL would otherwise evaluate for every sample (llvmpipe runs both sides of a branch).
#if defined(FACE_KIND) && FACE_KIND
#define u_face_ortho FACE_ORTHO
#define u_profile FACE_PROFILE
#define u_has_shadow FACE_SHADOW
#define u_has_gobo FACE_GOBO
#endif

vec3 light_space(vec3 p) { return (u_world_to_light * vec4(p, 1.0)).xyz; }

// Map coordinates in [0, 1]^2 of a light-space point in front of the light.
vec2 light_uv(vec3 q) { return 0.5 + 0.5 * q.xy / ((u_face_ortho == 1 ? 1.0 : -q.z) * u_tan_half); }

// Shadow-map coordinates (an orthographic face's shadow map covers its own rectangle).
vec2 shadow_uv(vec3 q) {
    if (u_face_ortho == 1) return 0.5 + 0.5 * (q.xy - u_shadow_rect.xy) / u_shadow_rect.zw;
    return light_uv(q);
}

// Distance along the light's ray from the face's origin (ortho: depth below its near plane).
float light_distance(vec3 q) { return u_face_ortho == 1 ? -q.z : length(q); }

// Direction the light travels at q, face space.
vec3 light_travel(vec3 q, float r) { return u_face_ortho == 1 ? vec3(0.0, 0.0, -1.0) : q / max(r, 1e-30); }

// Whether q belongs to this face: the cube faces split the sphere; a spot and a sun take all.
bool in_face(vec3 q) {
    if (u_profile == 0 || u_face_ortho == 1) return true;
    return q.z < 0.0 && all(lessThanEqual(abs(q.xy), -q.z * u_tan_half));
}

float spot_falloff(vec3 q);
float soft_spot_falloff(vec3 q);
float area_emission(vec3 q, float r);

// Intensity factor at q by direction (the spot cone, none, or the area light's cosine) times
// the distance falloff.
float emission_profile(vec3 q, float r) {
    if (u_face_ortho == 1) return 1.0;
    float f = 1.0 / (r * r);
    if (u_profile == 1) return f;
    if (u_profile == 2) return area_emission(q, r);
    return q.z < 0.0 ? f * soft_spot_falloff(q) : 0.0;
}

float spot_falloff(vec3 q) {
    vec3 s = vec3(q.xy / u_cone_scale, q.z);       // Cycles' elliptical cone: scaled, then round
    float c = -s.z / max(length(s), 1e-30);
    if (c <= u_cos_half) return 0.0;
    if (u_spot_smooth <= 0.0) return 1.0;
    float x = clamp((c - u_cos_half) / u_spot_smooth, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Fraction of the light reaching q (distance r) past the solids: a light with a size, the
// fraction of its shape (soft_shadow.glsl); a point, the hardware's 2x2 percentage-closer filter on the linear depth (distance / far).
// The bias is scale-free: g_bias_texels texel footprints at r, plus 2e-4 of the map's depth
// range. A lit surface needs a few footprints (else it shadows itself); a point of the medium is
// no occluder and needs none (a larger bias lets light leak through a solid just before it).
float g_bias_texels = 0.0;
float shadow_bias(float r) {
    float footprint = u_face_ortho == 1 ? max(u_shadow_rect.z, u_shadow_rect.w) : r * max(u_tan_half.x, u_tan_half.y);
    return g_bias_texels * footprint / u_map_res + 2e-4 * u_shadow_far;
}
#include "soft_shadow.glsl"
float solid_visibility(vec3 q, float r) {
    vec2 uv = shadow_uv(q);
    if (u_has_shadow == 0) return 1.0;
#if !MEDIUM_SHADOW
    // A point of the media, which no solid shadows. A define: the same test on a uniform saved
    // nothing on llvmpipe (docs/benchmark.md).
    if (g_bias_texels == 0.0) return 1.0;
#endif
    if (u_face_ortho == 1 && (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))))) return 1.0;
    float bias = shadow_bias(r);
#if SOFT_SHADOW
    return soft_visibility(q, uv, r, bias);
#endif
    return texture(u_shadow_depth, vec3(uv, (r - bias) / u_shadow_far));
}

vec3 gobo(vec2 uv) {
    if (u_has_gobo == 0) return vec3(1.0);
    return texture(u_gobo, vec2(uv.x, 1.0 - uv.y)).rgb;
}

// Henyey-Greenstein phase, cos_theta between the light's and the scattered direction.
float hg_phase(float cos_theta, float g) {
    float d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}
