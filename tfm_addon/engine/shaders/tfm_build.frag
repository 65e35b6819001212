#include "common.glsl"
// One texel per light ray of a face: march the media's weighted density from where the ray enters the medium (K_in) to
// where it leaves it or meets a solid (K_out), both tightened to where the density is not zero, and project F(x) = exp(-tau_D(x) / alpha_D)
// onto N_COEFF cosines, x in [0, 1] from K_in to K_out (METHOD.md section 3).
// With OPTICAL_DEPTH_ONLY the texel holds tau_D(1) alone (used to choose alpha automatically).
// u_occupancy holds the light marches' occupancy here (bindings.MediaGPU.bind_light_occupancy).
uniform int u_light_steps;
uniform float u_inv_alpha;          // 1 / alpha_D, per unit density integral (metres)

#ifdef OPTICAL_DEPTH_ONLY
out vec4 o_tau;
#else
layout(location = 0) out vec4 o_krange;   // K range and c0, c1; then c2..c5, c6..c9, ... (N_TARGETS)
#if N_TARGETS > 0
layout(location = 1) out vec4 o_coef0;
#endif
#if N_TARGETS > 1
layout(location = 2) out vec4 o_coef1;
#endif
#if N_TARGETS > 2
layout(location = 3) out vec4 o_coef2;
#endif
#if N_TARGETS > 3
layout(location = 4) out vec4 o_coef3;
#endif
#endif

void main() {
    vec2 uv = gl_FragCoord.xy / u_map_res;
    mat3 light_to_world = transpose(mat3(u_world_to_light));
    vec3 origin = u_light_pos;
    vec3 dir;
    vec2 suv = uv;
    if (u_face_ortho == 1) {
        vec3 q0 = vec3((uv * 2.0 - 1.0) * u_tan_half, 0.0);
        origin = u_light_pos + light_to_world * q0;
        dir = light_to_world * vec3(0.0, 0.0, -1.0);
        suv = shadow_uv(q0);
    } else {
        dir = light_to_world * normalize(vec3((uv * 2.0 - 1.0) * u_tan_half, -1.0));
    }

    vec2 k = media_interval(origin, dir);
    GridRay ray = grid_ray(origin, dir, u_med_weight[0]);
#if N_MEDIA == 1
    bool skip = MEDIA_SLOT[0] >= 0;    // a lone grid: its occupancy cells
#else
    bool skip = false;
#endif
    vec3 ob = (u_world_to_box * vec4(origin, 1.0)).xyz;
    vec3 db = (u_world_to_box * vec4(dir, 0.0)).xyz;
    float k_in = max(k.x, 0.0);
    float k_out = k.y;
    if (u_has_shadow == 1 && all(greaterThanEqual(suv, vec2(0.0))) && all(lessThanEqual(suv, vec2(1.0))))
    {
        // A solid nearer the light than the medium leaves the ray to the shadow map: T stays that of
        // the medium, so that filtering across a shadow edge does not blend in a T = 1 texel.
        float solid = texture(u_shadow, suv).r;
        if (solid > k_in) k_out = min(k_out, solid);
    }

#ifndef OPTICAL_DEPTH_ONLY
    // Tighten [K_in, K_out] to the part of the ray where the density is not zero, so that the
    // cosines spend their resolution where the transmittance changes.
    // The first and last samples with density are searched for from either end; samples in
    // empty occupancy cells are skipped (a lone grid), so an empty stretch costs a fetch per cell.
    if (k_out > k_in) {
        float dt = (k_out - k_in) / float(u_light_steps);
        // The grid's level for this ray (common.glsl): the texel's width where the ray enters the
        // medium (a sun: its own width) and the step; level 1 when both span two voxels.
        float width = 2.0 * min(u_tan_half.x, u_tan_half.y) * (u_face_ortho == 1 ? 1.0 : k_in) / u_map_res;
        ray.lod = grid_ray_lod(ray, dt, width);
        int first = u_light_steps;
        for (int m = 0; m < u_light_steps; ++m) {
            float t = k_in + (float(m) + 0.5) * dt;
            if (ray_density(ray, t) > 0.0) {
                first = m;
                break;
            }
            if (skip) m = max(m, int(ceil((skip_empty(ob, db, t) - k_in) / dt - 0.501)) - 1);
        }
        int last = -1;
        for (int m = u_light_steps - 1; m >= first; --m) {
            float t = k_in + (float(m) + 0.5) * dt;
            if (ray_density(ray, t) > 0.0) {
                last = m;
                break;
            }
            if (skip) m = min(m, int(floor((-skip_empty(ob, -db, -t) - k_in) / dt - 0.499)) + 1);
        }
        if (last < 0) {
            k_out = k_in;
        } else {
            k_out = k_in + float(min(last + 2, u_light_steps)) * dt;
            k_in = k_in + float(max(first - 1, 0)) * dt;
        }
    }
#endif
    float c[18];
    for (int j = 0; j < 18; ++j) c[j] = 0.0;
    float tau = 0.0;
    if (k_out > k_in) {
        float dt = (k_out - k_in) / float(u_light_steps);
        float dx = 1.0 / float(u_light_steps);
        float width = 2.0 * min(u_tan_half.x, u_tan_half.y) * (u_face_ortho == 1 ? 1.0 : k_in) / u_map_res;
        ray.lod = grid_ray_lod(ray, dt, width);     // the tightened steps may ask for level 0
        vec2 turn = vec2(cos(PI * dx), sin(PI * dx));         // cos, sin of pi x by rotation
        vec2 cs = vec2(cos(0.5 * PI * dx), sin(0.5 * PI * dx));
        for (int m = 0; m < u_light_steps; ++m) {
            float x = (float(m) + 0.5) * dx;
            float d = ray_density(ray, k_in + x * (k_out - k_in));
#ifndef OPTICAL_DEPTH_ONLY
            float f = exp(-(tau + 0.5 * d * dt) * u_inv_alpha);
            float c1 = cs.x;
            cs = vec2(cs.x * turn.x - cs.y * turn.y, cs.y * turn.x + cs.x * turn.y);
            float b_prev = 1.0;     // cos(0 pi x)
            float b = c1;           // cos(1 pi x)
            c[0] += f;
            for (int j = 1; j < N_COEFF; ++j) {
                c[j] += f * b;
                float b_next = 2.0 * c1 * b - b_prev;
                b_prev = b;
                b = b_next;
            }
#endif
            tau += d * dt;
        }
        for (int j = 0; j < 18; ++j) c[j] *= (j == 0 ? 1.0 : 2.0) * dx;
    } else {
        c[0] = 1.0;                 // a ray that misses the medium: F = 1
        k_in = 0.0;
        k_out = 0.0;
    }
#ifdef OPTICAL_DEPTH_ONLY
    o_tau = vec4(tau, 0.0, 0.0, 1.0);
#else
    o_krange = vec4(k_in, k_out, c[0], c[1]);
#if N_TARGETS > 0
    o_coef0 = vec4(c[2], c[3], c[4], c[5]);
#endif
#if N_TARGETS > 1
    o_coef1 = vec4(c[6], c[7], c[8], c[9]);
#endif
#if N_TARGETS > 2
    o_coef2 = vec4(c[10], c[11], c[12], c[13]);
#endif
#if N_TARGETS > 3
    o_coef3 = vec4(c[14], c[15], c[16], c[17]);
#endif
#endif
}
