// The transmittance from a light face to a point, by the method LIGHT_T:
// 0 TFM lookup, 1 march (brute force), 2 analytic (homogeneous), 3 none (the light's rays never
// cross the medium). Needs common.glsl.
uniform vec3 u_sigma_t;        // 1/m per unit density
uniform int u_light_steps;
uniform vec3 u_tfm_exponent;   // alpha_D * sigma_t: T = F^exponent
uniform sampler2D u_krange;
uniform sampler2D u_coef0;
uniform sampler2D u_coef1;
uniform sampler2D u_coef2;
uniform sampler2D u_coef3;

#if LIGHT_T == 2
// The box's extent behind the last lookup's point, away from the light (the octaves' light ray
// beyond the point: octaves.glsl).
float g_box_behind = 0.0;
#endif
#if LIGHT_T == 0
#if SOFT_SHADOW
vec2 g_tfm_domain = vec2(0.0);     // K in, K out of the last filtered read (soft_tfm_lookup)
float g_surface_f = -1.0;          // a lit surface's F, its light samples' mean (soft_surface)
#endif
// F at the far end of the last lookup's light ray (x = 1, cos(j pi) = (-1)^j: the transmittance
// through the whole medium there), for the multiple-scattering octaves (octaves.glsl).
float g_tfm_end = 1.0;

// Coefficient j of a map's texel: j = 0, 1 in the K range texture's z, w, then four per texture
// (u_coef0: 2..5, u_coef1: 6..9, ...). A map may hold more coefficients than the N_COEFF read
// (a wider map serves a narrower request): the mask zeroes those past N_COEFF.
vec4 coef_mask(int group) {
    return vec4(lessThan(vec4(float(2 + 4 * group)) + vec4(0.0, 1.0, 2.0, 3.0), vec4(float(N_COEFF))));
}

// F(x) from the K range and c0, c1 (kc) and the coefficients c2.. (four per vec4) at distance r
// from the light, clamped to [0, 1]. The cosines cos(j pi x) come four at a time from
// cos((j + 4) t) = 2 cos(4 t) cos(j t) - cos((j - 4) t), after one cos.
float tfm_series(vec4 kc, vec4 c0, vec4 c1, vec4 c2, vec4 c3, float r) {
#ifdef OCTAVES
    vec4 alt = vec4(1.0, -1.0, 1.0, -1.0);
    g_tfm_end = clamp(kc.z - kc.w * float(N_COEFF > 1) + dot(c0 * coef_mask(0), alt) * float(N_TARGETS > 0)
                      + dot(c1 * coef_mask(1), alt) * float(N_TARGETS > 1)
                      + dot(c2 * coef_mask(2), alt) * float(N_TARGETS > 2)
                      + dot(c3 * coef_mask(3), alt) * float(N_TARGETS > 3), 0.0, 1.0);
#endif
    float x = (r - kc.x) / max(kc.y - kc.x, 1e-6);
    if (x <= 0.0) return 1.0;
    float t1 = cos(PI * min(x, 1.0));
    float f = kc.z + kc.w * t1 * float(N_COEFF > 1);
#if N_TARGETS > 0
    float t2 = 2.0 * t1 * t1 - 1.0;
    float t3 = 2.0 * t1 * t2 - t1;
    float t4 = 2.0 * t2 * t2 - 1.0;
    float t5 = 2.0 * t1 * t4 - t3;
    vec4 b_prev = vec4(t2, t1, 1.0, t1);          // cos(j t) for j = -2 .. 1
    vec4 b = vec4(t2, t3, t4, t5);
    f += dot(c0 * coef_mask(0), b);
#endif
#if N_TARGETS > 1
    vec4 b_next = 2.0 * t4 * b - b_prev;
    b_prev = b;
    b = b_next;
    f += dot(c1 * coef_mask(1), b);
#endif
#if N_TARGETS > 2
    b_next = 2.0 * t4 * b - b_prev;
    b_prev = b;
    b = b_next;
    f += dot(c2 * coef_mask(2), b);
#endif
#if N_TARGETS > 3
    b_next = 2.0 * t4 * b - b_prev;
    f += dot(c3 * coef_mask(3), b_next);
#endif
    return clamp(f, 0.0, 1.0);
}

// F in one texel's own domain.
float tfm_texel(ivec2 c, float r) {
    vec4 zero = vec4(0.0);
    return tfm_series(texelFetch(u_krange, c, 0),
#if N_TARGETS > 0
                      texelFetch(u_coef0, c, 0),
#else
                      zero,
#endif
#if N_TARGETS > 1
                      texelFetch(u_coef1, c, 0),
#else
                      zero,
#endif
#if N_TARGETS > 2
                      texelFetch(u_coef2, c, 0),
#else
                      zero,
#endif
#if N_TARGETS > 3
                      texelFetch(u_coef3, c, 0),
#else
                      zero,
#endif
                      r);
}

// F at map coordinates uv, the hardware blending the 2x2 nearest texels' domains and coefficients
// (one fetch per texture; mixes domains where neighbouring texels differ).
float tfm_filtered(vec2 uv, float r) {
    vec4 zero = vec4(0.0);
    vec4 kc = texture(u_krange, uv);
#if SOFT_SHADOW
    g_tfm_domain = kc.xy;
#endif
    return tfm_series(kc,
#if N_TARGETS > 0
                      texture(u_coef0, uv),
#else
                      zero,
#endif
#if N_TARGETS > 1
                      texture(u_coef1, uv),
#else
                      zero,
#endif
#if N_TARGETS > 2
                      texture(u_coef2, uv),
#else
                      zero,
#endif
#if N_TARGETS > 3
                      texture(u_coef3, uv),
#else
                      zero,
#endif
                      r);
}

// F at map coordinates uv. TFM_FILTER 0: the 2x2 nearest texels are each reconstructed in their
// own domain, then blended (exact domains, 4x the fetches). 1: tfm_filtered.
float tfm_lookup(vec2 uv, float r) {
#if TFM_FILTER == 1
    return tfm_filtered(uv, r);
#else
    int res = textureSize(u_krange, 0).x;      // the TFM's own side (may differ from the shadow map's)
    vec2 f = uv * float(res) - 0.5;
    ivec2 i0 = ivec2(floor(f));
    vec2 w = f - floor(f);
    float v = 0.0;
    float end = 0.0;
    for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
            ivec2 c = clamp(i0 + ivec2(dx, dy), ivec2(0), ivec2(res - 1));
            float wt = (dx == 1 ? w.x : 1.0 - w.x) * (dy == 1 ? w.y : 1.0 - w.y);
            v += tfm_texel(c, r) * wt;
            end += g_tfm_end * wt;
        }
    }
    g_tfm_end = end;
    return v;
#endif
}

#if SOFT_SHADOW
// The spread (soft_shadow.glsl) of the middle of the medium along the light ray to a point at r:
// between the entry k.x of the ray's K range and the point, or its exit k.y; 0 without medium.
float medium_spread(vec2 k, float r) {
    return k.y > k.x ? max(soft_spread(max(0.5 * (k.x + min(k.y, r)), 1e-3 * r), r), 0.0) : 0.0;
}

// F for the light sample (soft_shadow.glsl): the map read where the ray from its point crosses
// the middle of the medium, with the K range the previous read found (along a view ray, a step
// away; on a surface, the previous light sample's; none before the first, which reads the centre).
float soft_tfm_lookup(vec3 q, vec2 uv, float r) {
    vec2 scale = soft_uv_scale(q, r, vec4(0.0, 0.0, u_tan_half));
    float f = tfm_filtered(uv + g_soft_e * scale * medium_spread(g_tfm_domain, r), r);
    return g_surface_f >= 0.0 ? g_surface_f : f;
}
#endif
#endif

// Unit direction from p toward the light, world (q: p in face space, r: light_distance).
vec3 toward_light(vec3 p, vec3 q, float r) {
    if (u_face_ortho == 1) return transpose(mat3(u_world_to_light)) * vec3(0.0, 0.0, 1.0);
    return (u_light_pos - p) / max(r, 1e-30);
}

// Transmittance from the light to p through the bounded media (q: p in light space, r: its
// light_distance).
vec3 media_light_transmittance(vec3 p, vec3 q, float r) {
#if LIGHT_T == 0
    vec2 uv = light_uv(q);
    g_tfm_end = 1.0;
    if (u_face_ortho == 1 && (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))))) return vec3(1.0);
#if SOFT_SHADOW
    return EXP2_RGB(u_tfm_exponent * log2(max(soft_tfm_lookup(q, uv, r), 1e-30)));
#endif
    return EXP2_RGB(u_tfm_exponent * log2(max(tfm_lookup(uv, r), 1e-30)));   // F^exponent, one log
#elif LIGHT_T == 1
    vec3 dir = toward_light(p, q, r);
    vec2 k = media_interval(p, dir);
    float a = max(k.x, 0.0);
    float b = min(k.y, r);
    if (b <= a) return vec3(1.0);
    float dt = (b - a) / float(u_light_steps);
#if N_MEDIA == 1
    if (MEDIA_SLOT[0] >= 0) {      // a lone grid: the TFM build's density path (common.glsl)
        GridRay ray = grid_ray(p, dir, 1.0);
        ray.lod = grid_ray_lod(ray, dt, dt);    // level 1 where the steps span two voxels
        float s = 0.0;
        for (int i = 0; i < u_light_steps; ++i) s += ray_density(ray, a + (float(i) + 0.5) * dt);
        return EXP_RGB(-u_med_sigma_t[0] * (s * dt));
    }
#endif
    vec3 tau = vec3(0.0);
    for (int i = 0; i < u_light_steps; ++i) tau += extinction_at(p + dir * (a + (float(i) + 0.5) * dt));
    return EXP_RGB(-tau * dt);
#elif LIGHT_T == 2
#if MEDIUM == 2
    return exp(-u_sigma_t * r);
#else
    vec3 dir = toward_light(p, q, r);
    vec2 k = box_interval(p, dir);
    g_box_behind = max(-k.x, 0.0);
    return EXP_RGB(-u_sigma_t * max(min(k.y, r) - max(k.x, 0.0), 0.0));
#endif
#else
    return vec3(1.0);
#endif
}

#if WORLD_FOG
// Fog without bounds beside the media (passes/bindings.MediaGPU.fog): homogeneous, everywhere.
uniform vec3 u_fog_sigma_t;    // 1/m
uniform vec3 u_fog_sigma_s;    // 1/m
uniform float u_fog_g;
#endif

// Transmittance from the light to p (q: p in light space, r: its light_distance): the media's,
// times the world fog's closed form along the r metres from the light (frame_plan drops the
// faces of a sun, whose light the fog absorbs altogether).
vec3 light_transmittance(vec3 p, vec3 q, float r) {
#if WORLD_FOG
    return media_light_transmittance(p, q, r) * exp(-u_fog_sigma_t * r);
#else
    return media_light_transmittance(p, q, r);
#endif
}

#if SOFT_SHADOW
#ifndef SOFT_SURFACE_MAP_SHARE
#define SOFT_SURFACE_MAP_SHARE 3
#endif
// A lit surface's light samples (scatter.frag, once per pixel and sample, before light_arriving,
// which then reads their means; soft_shadow.glsl): the solids' visibility and the spot cone or a
// spread area light's emission over SOFT_SURFACE_SAMPLES of them, the map's F over a third as
// many (SOFT_SURFACE_MAP_SHARE), weighted by what a spread area light sends from each. Only
// the face that lights q takes them (a spot's: only within reach of its cone).
void soft_surface(vec3 q, float r) {
#if FACE_PROFILE == 0
    int n = spot_reaches(q) ? SOFT_SURFACE_SAMPLES : 0;     // a spot's one face: its cone
#else
    int n = in_face(q) ? SOFT_SURFACE_SAMPLES : 0;
#endif
    float vis = 0.0;
    float shape = 0.0;
    for (int k = 0; k < n; ++k) {
        soft_next();
#if AREA_SPREAD
        shape += area_emission(q, r);       // first: its point of the light is the sample's
#elif FACE_PROFILE == 0
        shape += soft_spot_falloff(q);
#endif
        vis += surface_visibility(q, r);
    }
    g_surface_visibility = vis / float(SOFT_SURFACE_SAMPLES);
#if LIGHT_T == 0
    vec2 uv = light_uv(q);
    g_tfm_domain = texelFetch(u_krange, ivec2(uv * vec2(textureSize(u_krange, 0))), 0).xy;
    float f = 0.0;
    float weights = 0.0;
    // No medium along the centre's ray: the map's reads are skipped (F 1, as at the centre).
    int m = g_tfm_domain.y > g_tfm_domain.x ? n / SOFT_SURFACE_MAP_SHARE : 0;
    for (int k = 0; k < m; ++k) {
        soft_next();
#if AREA_SPREAD
        float w = area_emission(q, r);
#else
        float w = 1.0;
#endif
        f += w * soft_tfm_lookup(q, uv, r);
        weights += w;
    }
    g_surface_f = weights > 0.0 ? f / weights : 1.0;
#endif
    g_surface_shape = shape / float(SOFT_SURFACE_SAMPLES);
}

// After the surface: the next points are the medium's.
void soft_surface_end() {
    g_soft_normal = vec3(0.0);
    g_surface_visibility = -1.0;
    g_surface_shape = -1.0;
#if LIGHT_T == 0
    g_surface_f = -1.0;
#endif
}
#endif
