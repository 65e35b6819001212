// Shared by the fragment shaders: the medium's bounds and density, the spot light, the phase.
const float PI = 3.14159265358979;
const float NO_HIT = 1e30;

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

// Density at a point given in box (grid index) space: trilinear between voxel centres.
float density_at_index(vec3 idx) {
    return texture(u_density, (idx + 1.5) / u_grid_size).r * u_density_scale;
}

// Empty-space skipping: u_occupancy is 1 where a cell of u_occupancy_block^3 padded voxels may
// hold non-zero density (passes/bindings.occupancy). The ray parameter where the ray ob + db t
// (box space) leaves the empty cell holding its point at t, or t when that cell is not empty.
uniform sampler3D u_occupancy;
uniform float u_occupancy_block;
float skip_empty(vec3 ob, vec3 db, float t) {
    ivec3 cell = clamp(ivec3(floor((ob + db * t + 1.0) / u_occupancy_block)), ivec3(0),
                       textureSize(u_occupancy, 0) - 1);
    if (texelFetch(u_occupancy, cell, 0).r > 0.0) return t;
    db = mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
    vec3 tb = ((vec3(cell) + step(0.0, db)) * u_occupancy_block - 1.0 - ob) / db;
    return max(t, min(min(tb.x, tb.y), tb.z));
}

// Density at a world point.
float density_at(vec3 p) {
    return density_at_index((u_world_to_box * vec4(p, 1.0)).xyz);
}

// ---- the spot light ----
uniform mat4 u_world_to_light;   // rigid: the light at the origin shining along -Z
uniform vec3 u_light_pos;
uniform vec3 u_intensity;        // W/sr per channel
uniform float u_cos_half;        // cos of half the cone angle (in the cone's scaled space)
uniform float u_spot_smooth;     // (1 - cos_half) * blend
uniform vec2 u_tan_half;         // half-widths of the map frustum at unit distance, x and y
uniform vec2 u_cone_scale;       // an elliptical cone's x, y scale (object scale x/z, y/z)
uniform float u_map_res;         // texels per side of the shadow map and TFM
uniform int u_has_shadow;
uniform sampler2D u_shadow;      // distance from the light to the nearest solid, metres
uniform sampler2DShadow u_shadow_depth;   // the same as depth, distance / u_shadow_far
uniform float u_shadow_far;     // metres; the depth texture holds distance / far (linear)
uniform int u_has_gobo;
uniform sampler2D u_gobo;

vec3 light_space(vec3 p) { return (u_world_to_light * vec4(p, 1.0)).xyz; }

// Map coordinates in [0, 1]^2 of a light-space point in front of the light.
vec2 light_uv(vec3 q) { return 0.5 + 0.5 * q.xy / (-q.z * u_tan_half); }

float spot_falloff(vec3 q) {
    vec3 s = vec3(q.xy / u_cone_scale, q.z);       // Cycles' elliptical cone: scaled, then round
    float c = -s.z / max(length(s), 1e-30);
    if (c <= u_cos_half) return 0.0;
    if (u_spot_smooth <= 0.0) return 1.0;
    float x = clamp((c - u_cos_half) / u_spot_smooth, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Fraction of the light reaching distance r along the map direction uv past the solids:
// the hardware's 2x2 percentage-closer filter on the linear depth (distance / far).
// The bias is scale-free: g_bias_texels texel footprints at r, plus 2e-4 of the map's depth
// range. A lit surface needs a few footprints (else it shadows itself); a point of the medium is
// no occluder and needs none (a larger bias lets light leak through a solid just before it).
float g_bias_texels = 0.0;
float solid_visibility(vec2 uv, float r) {
    if (u_has_shadow == 0) return 1.0;
    float bias = r * (g_bias_texels * max(u_tan_half.x, u_tan_half.y) / u_map_res) + 2e-4 * u_shadow_far;
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
