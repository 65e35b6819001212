// The camera pass for one spot light (HAS_LIGHT) and, on the first pass, for the ambient light
// (FIRST_PASS): light scattered toward the camera, the solids' radiance before the medium in
// front of them, and the view transmittance. Passes add up (blending ONE, ONE).
//
// MEDIUM: 0 none, 1 homogeneous box, 2 homogeneous everywhere, 3 density grid.
// LIGHT_T: how the transmittance from the light is found (transmittance.glsl).
// PROJECTIVE: space the samples of a homogeneous medium uniformly in the light's map space.
#include "common.glsl"
#include "transmittance.glsl"
#include "emission.glsl"
#include "fire_light.glsl"
#include "surface.glsl"
#include "octaves.glsl"
#include "view.glsl"

uniform sampler2D u_gb0;       // base colour, distance
uniform sampler2D u_gb1;       // normal, roughness and metallic, hit flag (gbuffer_pack.glsl)
uniform vec2 u_clip;           // clip start, end: depths along the view axis, metres
uniform vec3 u_sigma_s;        // 1/m per unit density
uniform float u_g;
uniform vec3 u_ambient;         // the world radiance the media scatter (first pass)
uniform vec3 u_ambient_surface; // ... and the surfaces reflect
uniform int u_view_steps;
uniform int u_light_in_medium;
uniform float u_view_jitter;   // < 0: march at step midpoints; else this sample's start offset
uniform vec2 u_window_origin;  // the window's lower-left pixel in the frame (a border or a tile)
#if SUMS
// A lone light pass of an antialiasing sample adds the sample straight into the frame's sums, as
// composite.frag's ACCUMULATE would (compose.glsl's SAMPLE_SUMS outputs).
#define SAMPLE_SUMS 1
#include "compose.glsl"
#else
layout(location = 0) out vec4 o_scatter;
layout(location = 1) out vec4 o_surface;
layout(location = 2) out vec4 o_transmittance;
#if COMPOSE
// A lone light pass (no other pass adds to its targets) writes the combined image too, so that
// no composite pass follows (compose.glsl: what composite.frag would write).
#include "compose.glsl"
layout(location = 3) out vec4 o_combined;
#endif
#endif

#if HAS_LIGHT
uniform vec3 u_light_targets;    // what the light lights: the media (x) and the surfaces (y), 0 or 1;
                                 // z 0: the media cast no shadow from it on the surfaces (shadow linking)
uniform uvec4 u_unlit_entries;   // bit k: the light does not light material table entry k (light linking)
#ifdef N_MEDIA
uniform float u_med_unlit[MAX_MEDIA];   // 1: the light does not light that medium (light linking)
#endif

// 1 where the light lights the surface of G-buffer hit flag ``flag`` (1 + 2 k), else 0.
float lights_entry(float flag) {
    int k = int(floor((flag - 1.0) * 0.5 + 0.5));
    return float(((u_unlit_entries[k >> 5] >> uint(k & 31)) & 1u) == 0u);
}

#include "light_reaching.glsl"

// Part of the ray (o, d) inside the pyramid that bounds the light's cone.
vec2 frustum_interval(vec3 o, vec3 d, vec2 range) {
    vec3 oq = light_space(o);
    vec3 dq = mat3(u_world_to_light) * d;
    if (u_face_ortho == 1) return range;       // a sun lights the whole segment
    vec4 A = vec4(-oq.z * u_tan_half.x - oq.x, -oq.z * u_tan_half.x + oq.x,
                  -oq.z * u_tan_half.y - oq.y, -oq.z * u_tan_half.y + oq.y);
    vec4 B = vec4(-dq.z * u_tan_half.x - dq.x, -dq.z * u_tan_half.x + dq.x,
                  -dq.z * u_tan_half.y - dq.y, -dq.z * u_tan_half.y + dq.y);
    for (int i = 0; i < 4; ++i) {
        if (abs(B[i]) < 1e-12) {
            if (A[i] < 0.0) return vec2(1.0, 0.0);
        } else if (B[i] > 0.0) {
            range.x = max(range.x, -A[i] / B[i]);
        } else {
            range.y = min(range.y, -A[i] / B[i]);
        }
    }
    return range;
}
#include "world_soft.glsl"
#endif
#include "homogeneous.glsl"

#if MS_GRID
#define MS_BOX_STEPS 8
// The light scattered many times and the light the surfaces reflect into the media, as fluences
// on a lattice over the media (engine/diffusion.py), 0 outside it.
uniform sampler3D u_ms_fluence;  // their sum, weighed by the bounce count (passes/fluence.py)
uniform mat4 u_world_to_ms;       // world -> the lattice's texture coordinates
// At tc, the lattice's texture coordinates (stepped along the view ray: ms_ray).
vec3 ms_fluence(vec3 tc) {
    if (any(lessThan(tc, vec3(0.0))) || any(greaterThan(tc, vec3(1.0)))) return vec3(0.0);
    return texture(u_ms_fluence, tc).rgb;
}
// The lattice's texture coordinates of o (xyz) and their change per metre along d.
mat2x3 ms_ray(vec3 o, vec3 d) {
    return mat2x3((u_world_to_ms * vec4(o, 1.0)).xyz, mat3(u_world_to_ms) * d);
}
#endif

void main() {
    vec2 pc = u_plane0 + gl_FragCoord.xy * u_pixel_size;
    vec3 o;
    vec3 d;
    float t_near;
    float t_far;
    if (u_ortho == 1) {
        o = (u_camera_to_world * vec4(pc, 0.0, 1.0)).xyz;
        d = normalize(mat3(u_camera_to_world) * vec3(0.0, 0.0, -1.0));
        t_near = u_clip.x;
        t_far = u_clip.y;
    } else {
        vec3 dc = vec3(pc, -1.0);
        float len = length(dc);
        o = u_camera_to_world[3].xyz;
        d = mat3(u_camera_to_world) * (dc / len);
        t_near = u_clip.x * len;
        t_far = u_clip.y * len;
    }
    ivec2 px = ivec2(gl_FragCoord.xy);
#if SOFT_SHADOW
    soft_start();
#endif
    // Where in each step the march samples: the midpoint, or (antialiasing samples) the sample's
    // offset plus a per-pixel hash, so that neighbouring pixels and successive samples differ.
    float step_at = u_view_jitter < 0.0 ? 0.5
        : fract(u_view_jitter + fract(52.9829189 * fract(dot(vec2(px) + u_window_origin, vec2(0.06711056, 0.00583715)))));
    vec4 g0 = texelFetch(u_gb0, px, 0);
    vec4 g1 = texelFetch(u_gb1, px, 0);
    bool hit = g1.w > 0.5;
    float t_end = hit ? g0.w : t_far;

    vec3 scatter = vec3(0.0);
    vec3 surface = vec3(0.0);
    vec3 transmittance = vec3(1.0);
    float phase_g = u_g;

    if (hit && abs(g1.w - 2.0) > 0.5) {      // a surface (a holdout has no radiance)
        vec3 n = octahedral_decode(g1.xy);
        if (dot(n, d) > 0.0) n = -n;
        vec3 P = o + d * g0.w;
        SurfacePoint sp = surface_point(g1.w, g0.rgb, unpack_rough_metal(g1.z));
        Lobes lobes = surface_lobes(sp, dot(n, -d));
#if FIRST_PASS
        surface += surface_albedo(sp, lobes) * u_ambient_surface + sp.emission;
#if FIRE_LIGHT
        surface += surface_albedo(sp, lobes) / PI * fire_irradiance(P, n);
#endif
#endif
#if HAS_LIGHT
        vec3 qP = light_space(P);
        vec3 L = toward_light(P, qP, light_distance(qP));
#if FACE_WORLD_SOFT
        // A world sun lights the surface from its whole cone (world_sun_arriving: each direction
        // weighted by its own cosine), through the BSDF's value at the cone's axis (the diffuse
        // albedo where the axis is below the surface).
        float ndl_axis = dot(n, L);
        vec3 brdf = ndl_axis > 0.05 ? surface_bsdf_cos(sp, lobes, n, -d, L) / ndl_axis
                                    : surface_albedo(sp, lobes) / PI;
        g_bias_texels = 3.0;
        surface += brdf * world_sun_arriving(P, qP, mat3(u_world_to_light) * n, step_at)
                   * u_light_targets.y;
        g_bias_texels = 0.0;
#else
        vec3 f = surface_bsdf_cos(sp, lobes, n, -d, L);
        if (any(greaterThan(f, vec3(0.0)))) {
            float r;
            // The solid's own shadow-map texels must not shadow it: 3 footprints, and as many
            // as its depth changes across one where the light grazes it (slope-scaled).
            g_bias_texels = surface_bias_texels(dot(n, L));
#if SOFT_SHADOW
            g_soft_normal = mat3(u_world_to_light) * n;     // its plane, for the soft shadow's samples
            soft_surface(qP, light_distance(qP));           // its light samples (transmittance.glsl)
#endif
            vec3 t_light;
            vec3 li = light_reaching(P, qP, r, t_light);
            surface += f * li * mix(vec3(1.0), t_light, u_light_targets.z) * u_light_targets.y
                       * lights_entry(g1.w);
            g_bias_texels = 0.0;
#if SOFT_SHADOW
            soft_surface_end();
#endif
        }
#endif
#endif
    }

#if MEDIUM != 0
#if MEDIUM == 2
    vec2 seg = vec2(t_near, t_end);
#elif MEDIUM == 3
    vec2 seg = media_interval(o, d);
#if GLOW_BLOCKS
    vec2 dens_seg = seg;    // where the density may not be 0: outside it a skip may pass a whole glow block
#endif
#if EMISSION
    // The boxes are the densities' non-zero bounds; the first medium's emission may glow outside.
    vec2 emit_seg = emission_interval((u_world_to_box * vec4(o, 1.0)).xyz, (u_world_to_box * vec4(d, 0.0)).xyz);
    if (emit_seg.y > emit_seg.x)
        seg = seg.y > seg.x ? vec2(min(seg.x, emit_seg.x), max(seg.y, emit_seg.y)) : emit_seg;
#endif
    seg = vec2(max(seg.x, t_near), min(seg.y, t_end));
#else
    vec2 seg = box_interval(o, d);
    seg = vec2(max(seg.x, t_near), min(seg.y, t_end));
#endif
    if (seg.y > seg.x) {
#if MEDIUM == 3
        // Every medium along the ray: one march for the view transmittance and the scattered
        // light; overlapping media add their coefficients, the phase is their sigma_s mixture.
        float dt = (seg.y - seg.x) / float(u_view_steps);
        vec3 tau = vec3(0.0);
#if WORLD_FOG
        tau = u_fog_sigma_t * (seg.x - t_near);     // the fog before the media
#endif
        // The first medium's index space: its emission and colour grid (fire's attributes).
        vec3 ob = (u_world_to_box * vec4(o, 1.0)).xyz;
        vec3 db = (u_world_to_box * vec4(d, 0.0)).xyz;
#if EMISSION
        vec2 emit = emission_interval(ob, db);
        vec3 glow = vec3(0.0);      // the emission's sum over samples, each times its transmittance
#endif
        float t_stop = seg.y;       // past it this pass adds nothing
#if HAS_LIGHT
        vec3 oq = light_space(o);
        vec3 dq = mat3(u_world_to_light) * d;
#if !FIRST_PASS
        // A later pass adds only this face's light: it marches the same samples as the first
        // pass but stops where the ray leaves the face's frustum (a sun's box: never).
        t_stop = frustum_interval(o, d, seg).y;
#endif
#endif
#if !PACKED_DENSITY && N_MEDIA == 1
        // One grid alone: its texture coordinates stepped along the ray (one fetch a sample, no
        // matrix product or box test: outside its non-zero bounds its trilinear density is 0).
        GridRay vray = grid_ray(o, d, 1.0);
#endif
#if MS_GRID && FIRST_PASS
        mat2x3 ms_tc = ms_ray(o, d);
#endif
#if PACKED_DENSITY
        // The same for the texture that packs the first medium's density (emission.glsl).
        vec3 ptc0 = (ob + 1.5) / PACKED_SIZE;
        vec3 ptcd = db / PACKED_SIZE;
#endif
        for (int i = 0; i < u_view_steps; ++i) {
            float t = seg.x + (float(i) + step_at) * dt;
            if (t > t_stop) break;
            vec3 p = o + d * t;
            float D[N_MEDIA];
            bool any_d = false;
            vec3 st = vec3(0.0);
#if PACKED_DENSITY
            vec4 pk = packed_fetch(ptc0 + ptcd * t);  // the first medium's density and emission or colour
#endif
            for (int m = 0; m < N_MEDIA; ++m) {
#if PACKED_DENSITY
                D[m] = m == 0 ? packed_density(pk) : medium_density(m, p);
#elif N_MEDIA == 1
                D[m] = MEDIA_SLOT[0] >= 0 ? grid0(vray.tc0 + vray.tcd * t, 0.0) * vray.scale
                                          : medium_density(m, p);
#else
                D[m] = medium_density(m, p);
#endif
                any_d = any_d || D[m] > 0.0;
                st += u_med_sigma_t[m] * D[m];
            }
#if WORLD_FOG
            st += u_fog_sigma_t;
            any_d = true;           // the fog fills the empty cells: no skipping
#endif
            // The step's exact share of its source terms: the view transmittance's integral over
            // it (the extinction constant there), for this sample and those it skips.
            vec3 w_step = EXP_RGB(-tau) * step_integral(st, dt, EXP_RGB(-st * dt));
#if EMISSION
#if PACKED_DENSITY == 1 && EMISSION == 2
            glow += w_step * emission_of(pk);     // 0 outside the emitting voxels' box: no constant part
#elif PACKED_DENSITY == 1
            if (t >= emit.x && t <= emit.y) glow += w_step * emission_of(pk);
#else
            if (t >= emit.x && t <= emit.y) glow += w_step * emission_at_index(ob + db * t);
#endif
#if GLOW_BLOCKS
            // The constant part, where Cycles' volume mesh is (emission.glsl glow_at).
            float in_glow = glow_at(ob + db * t);
            glow += w_step * u_emission_const * in_glow;
#endif
#endif
#if N_MEDIA == 1
            if (!any_d) {     // in an empty occupancy cell: on to the first sample past it (at step_at)
#if GLOW_BLOCKS
                // ... or past this glow block, whichever comes first: the samples skipped then all
                // lie in this sample's block and glow as it does.
                float t_skip = glow_exit(ob, db, t);
                if (t < dens_seg.x) t_skip = min(t_skip, dens_seg.x);       // before the density's box
                else if (t <= dens_seg.y) t_skip = min(t_skip, skip_empty(ob, db, t));
                int next = max(i + 1, int(ceil((t_skip - seg.x) / dt - step_at - 0.001)));
                glow += float(min(next, u_view_steps) - i - 1) * w_step * u_emission_const * in_glow;
#else
                int next = max(i + 1, int(ceil((skip_empty(ob, db, t) - seg.x) / dt - step_at - 0.001)));
#endif
#if EMISSION && EMISSION != 2 && !GLOW_BLOCKS
                // The samples skipped (no density, no emitting voxel near) glow with the constant
                // part of the emission alone, each with this step's share (st is 0).
                glow += float(samples_within(emit, i + 1, min(next, u_view_steps), seg.x, dt, step_at))
                    * w_step * emission_constant();
#endif
                i = next - 1;
            }
#endif
            if (any_d) {
                vec3 tint0 = vec3(1.0);     // the first medium's scattering colour per voxel
#if PACKED_DENSITY == 3
                tint0 = pk.rgb;
#elif COLOR_GRID
                tint0 = color_at_index(ob + db * t);
#endif
                vec3 ss = vec3(0.0);
                for (int m = 0; m < N_MEDIA; ++m) ss += u_med_sigma_s[m] * (m == 0 ? tint0 : vec3(1.0)) * D[m];
#if WORLD_FOG
                ss += u_fog_sigma_s;
#endif
                vec3 src = vec3(0.0);
#if FIRST_PASS
                src += ss * u_ambient;
#if MS_GRID
                src += ss * ms_fluence(ms_tc[0] + ms_tc[1] * t) * (0.25 / PI);   // scattered isotropically
#endif
#endif
#if HAS_LIGHT
                // The light is read where the camera sees into the step on average (that depth
                // times 2 step_at: the mean over antialiasing samples), not at the density's sample.
                float t_l = seg.x + (float(i) + 2.0 * step_at * seen_fraction(dot(st, vec3(dt / 3.0)))) * dt;
                vec3 p_l = o + d * t_l;
                vec3 q = oq + dq * t_l;
                float r;
                vec3 t_light;
                vec3 li = light_reaching(p_l, q, r, t_light);
                if (any(greaterThan(li, vec3(0.0)))) {
                    float c = -dot(light_travel(q, r), dq);
                    vec3 tau_through = light_through(p_l, q, r, t_light);
                    vec3 tau_v = tau + st * (t_l - seg.x - float(i) * dt);
                    vec3 ssp = vec3(0.0);
                    for (int m = 0; m < N_MEDIA; ++m) {
                        vec3 sigma_s = u_med_sigma_s[m] * (m == 0 ? tint0 : vec3(1.0));
                        ssp += sigma_s * (D[m] * (1.0 - u_med_unlit[m]))
                               * octave_phase(t_light, tau_through, tau_v, c, u_med_g[m],
                                              sigma_s / max(u_med_sigma_t[m], vec3(1e-12)));
                    }
#if WORLD_FOG
                    ssp += u_fog_sigma_s * octave_phase(t_light, tau_through, tau_v, c, u_fog_g,
                                                        u_fog_sigma_s / max(u_fog_sigma_t, vec3(1e-12)));
#endif
                    src += li * ssp * u_light_targets.x;
                }
#endif
                scatter += w_step * src;
                tau += st * dt;
#if GREY_EXTINCTION
                if (tau.r > 6.9078) break;                             // view transmittance < 1e-3
#else
                if (min(min(tau.r, tau.g), tau.b) > 6.9078) break;    // view transmittance < 1e-3
#endif
            }
        }
        transmittance = EXP_RGB(-tau);
#if EMISSION
        scatter += glow;
#endif
#else
        // Homogeneous: analytic transmittance and ambient term.
        float len = seg.y - seg.x;
        transmittance = exp(-u_sigma_t * len);
#if FIRST_PASS
        vec3 ratio = mix(u_sigma_s / max(u_sigma_t, vec3(1e-12)), vec3(len) * u_sigma_s,
                         lessThan(u_sigma_t, vec3(1e-12)));
        scatter += ratio * u_ambient * mix(1.0 - transmittance, vec3(1.0), lessThan(u_sigma_t, vec3(1e-12)));
#if MS_GRID
        {   // the lattice's fields, marched through the box (each step weighted by its exact share;
            // they vary over a lattice cell: at most MS_BOX_STEPS steps)
            int n_f = min(u_view_steps, MS_BOX_STEPS);
            float dt_f = len / float(n_f);
            vec3 e_f = exp(-u_sigma_t * dt_f);
            vec3 w_f = step_integral(u_sigma_t, dt_f, e_f);
            vec3 t_f = vec3(1.0);
            mat2x3 ms_tc = ms_ray(o, d);
            for (int i = 0; i < n_f; ++i) {
                vec3 tc = ms_tc[0] + ms_tc[1] * (seg.x + (float(i) + step_at) * dt_f);
                scatter += t_f * w_f * u_sigma_s * ms_fluence(tc) * (0.25 / PI);
                t_f *= e_f;
                if (max(max(t_f.r, t_f.g), t_f.b) < 1e-3) break;
            }
        }
#endif
#endif
#if EMISSION
        scatter += emission_at_index(vec3(0.0)) * mix((1.0 - transmittance) / max(u_sigma_t, vec3(1e-12)),
                                                      vec3(len), lessThan(u_sigma_t, vec3(1e-12)));
#endif
#if HAS_LIGHT
        scatter += homogeneous_light(o, d, frustum_interval(o, d, seg), seg.x, u_sigma_t, u_sigma_s, phase_g,
                                     step_at, PROJECTIVE == 1);
#endif
#endif
    }
#if WORLD_FOG
    world_fog_outside(o, d, vec2(t_near, t_end), seg, step_at, scatter, transmittance);
#endif
#endif

#if SUMS
    add_to_sums(scatter, surface, transmittance, g1.w, gl_FragCoord.xy);
#else
#if FIRST_PASS
    o_transmittance = vec4(transmittance, 1.0);
#else
    o_transmittance = vec4(0.0);
#endif
    o_scatter = vec4(scatter, 0.0);
    o_surface = vec4(surface, 0.0);
#if COMPOSE
    o_combined = combined_pixel(scatter, surface, transmittance, g1.w, gl_FragCoord.xy);
#endif
#endif
}
