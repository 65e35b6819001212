// Solid surfaces as Cycles' Principled BSDF lights them directly (engine/surface.py): metal (GGX,
// F82-tint Fresnel), dielectric specular (GGX, the real Fresnel remapped to F0..1) and Lambert
// diffuse under it, each GGX lobe energy-compensated when it is Multiscatter GGX.
// The G-buffer's hit flag names the pixel's material: 1 + 2 k for material k, 2 a holdout.

#include "gbuffer_pack.glsl"

#include "materials.glsl"
// Cycles' microfacet tables (surface.ggx_tables), four floats a vec4.
layout(std140) uniform GgxFresnel {
    vec4 u_s_ior[1024];                     // [z][mu][rough], 16 each
};
layout(std140) uniform GgxAlbedo {
    vec4 u_ggx[328];                        // E [mu][rough] 32 x 32, Eavg [rough] 32, s5 [mu][rough] 16 x 16
};

struct SurfacePoint {
    vec3 base;
    float weight;
    float rough;
    float metal;
    float ior;
    bool multi;
    vec3 tint;
    bool constant_fresnel;
    vec3 emission;
};

SurfacePoint surface_point(float hit_flag, vec3 base, vec2 rough_metal) {
    int k = 4 * material_index(hit_flag);
    vec4 a = u_material[k];
    vec4 b = u_material[k + 1];
    vec4 c = u_material[k + 2];
    SurfacePoint s;
    s.base = base;        // the G-buffer's (the material's values, or its textures')
    s.weight = a.w;
    s.rough = rough_metal.x;
    s.metal = rough_metal.y;
    s.ior = b.z;
    s.multi = b.w > 0.5;
    s.tint = c.rgb;
    s.constant_fresnel = c.w > 0.5;
    s.emission = u_material[k + 3].rgb;
    return s;
}

float ggx_value(int i) { return u_ggx[i >> 2][i & 3]; }
float s_ior_value(int i) { return u_s_ior[i >> 2][i & 3]; }

// Cycles' lookup_table_read: linear along each axis at x (n - 1).
void table_cell(float x, int n, out int i0, out int i1, out float t) {
    float f = clamp(x, 0.0, 1.0) * float(n - 1);
    i0 = min(int(f), n - 1);
    i1 = min(i0 + 1, n - 1);
    t = f - float(i0);
}

float table_2d(int offset, int n, float x, float y) {
    int x0, x1, y0, y1;
    float tx, ty;
    table_cell(x, n, x0, x1, tx);
    table_cell(y, n, y0, y1, ty);
    float a = mix(ggx_value(offset + y0 * n + x0), ggx_value(offset + y0 * n + x1), tx);
    float b = mix(ggx_value(offset + y1 * n + x0), ggx_value(offset + y1 * n + x1), tx);
    return mix(a, b, ty);
}

float s_ior_table(float rough, float mu, float z) {
    int x0, x1, y0, y1, z0, z1;
    float tx, ty, tz;
    table_cell(rough, 16, x0, x1, tx);
    table_cell(mu, 16, y0, y1, ty);
    table_cell(z, 16, z0, z1, tz);
    float v[2];
    for (int k = 0; k < 2; ++k) {
        int base = (k == 0 ? z0 : z1) * 256;
        float a = mix(s_ior_value(base + y0 * 16 + x0), s_ior_value(base + y0 * 16 + x1), tx);
        float b = mix(s_ior_value(base + y1 * 16 + x0), s_ior_value(base + y1 * 16 + x1), tx);
        v[k] = mix(a, b, ty);
    }
    return mix(v[0], v[1], tz);
}

float F0_from_ior(float eta) {
    float f = (eta - 1.0) / (eta + 1.0);
    return f * f;
}

float fresnel_dielectric_cos(float c, float eta) {
    c = abs(c);
    float g = eta * eta - 1.0 + c * c;
    if (g <= 0.0) return 1.0;
    g = sqrt(g);
    float A = (g - c) / (g + c);
    float B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * A * A * (1.0 + B * B);
}

// Cycles' F82-tint: B from F0 and the tint, then Schlick minus B cos (1 - cos)^6.
vec3 f82_B(vec3 f0, vec3 tint) {
    return mix(f0, vec3(1.0), 0.46266436) * 17.651384 * (vec3(1.0) - tint);
}

vec3 fresnel_f82(float c, vec3 f0, vec3 B) {
    float s = clamp(1.0 - c, 0.0, 1.0);
    float s5 = (s * s) * (s * s) * s;
    return clamp(mix(f0, vec3(1.0), s5) - B * c * s5 * s, 0.0, 1.0);
}

// Per-lobe state at the view: its Fresnel parameters, single-scatter albedo factor and the
// multiscatter compensation (1 + Fms (1 - E) / E).
struct Lobes {
    float alpha2;
    vec3 metal_f0;
    vec3 metal_B;
    vec3 metal_comp;
    vec3 diel_f0;
    float diel_F0real;
    vec3 diel_comp;
    vec3 diel_albedo;       // the specular layer's albedo at this view (per unit weight)
    float diffuse;          // the diffuse layer's weight under it
    vec3 metal_albedo;
};

vec3 compensation(vec3 Fss, float E, float Eavg) {
    vec3 Fms = Fss * Eavg / (vec3(1.0) - Fss * (1.0 - Eavg));
    return vec3(1.0) + Fms * ((1.0 - E) / max(E, 1e-4));
}

Lobes surface_lobes(SurfacePoint s, float mu) {
    Lobes l;
    float alpha = s.rough * s.rough;
    l.alpha2 = alpha * alpha;
    float E = table_2d(0, 32, s.rough, mu);
    float Eavg = 0.0;
    {
        int x0, x1;
        float tx;
        table_cell(s.rough, 32, x0, x1, tx);
        Eavg = mix(ggx_value(1024 + x0), ggx_value(1024 + x1), tx);
    }
    // metal
    vec3 cc = clamp(s.base, 0.0, 1.0);
    l.metal_f0 = cc;
    l.metal_B = s.constant_fresnel ? vec3(0.0) : f82_B(cc, min(s.tint, vec3(1.0)));
    vec3 metal_Fss = s.constant_fresnel ? cc
        : clamp(mix(cc, vec3(1.0), 1.0 / 21.0) - l.metal_B * (1.0 / 126.0), 0.0, 1.0);
    l.metal_comp = s.multi ? compensation(metal_Fss, E, Eavg) : vec3(1.0);
    float s5 = table_2d(1056, 16, s.rough, mu);
    l.metal_albedo = (s.multi ? E + (l.metal_comp - 1.0) * E : vec3(1.0))
        * (s.constant_fresnel ? cc : mix(cc, vec3(1.0), s5));
    // dielectric specular (none at IOR 1)
    l.diel_F0real = F0_from_ior(s.ior);
    l.diel_f0 = l.diel_F0real * s.tint;
    l.diel_albedo = vec3(0.0);
    l.diel_comp = vec3(1.0);
    l.diffuse = 1.0;
    if (abs(s.ior - 1.0) > 1e-5) {
        float eta = s.ior;
        float real_Fss = eta < 1.0 ? 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607))
                                   : (eta - 1.0) / (4.08567 + 1.00071 * eta);
        float sf = clamp((real_Fss - l.diel_F0real) / max(1.0 - l.diel_F0real, 1e-6), 0.0, 1.0);
        vec3 Fss = mix(l.diel_f0, vec3(1.0), sf);
        l.diel_comp = s.multi ? compensation(Fss, E, Eavg) : vec3(1.0);
        float z = sqrt(abs((eta - 1.0) / (eta + 1.0)));
        vec3 albedo = mix(l.diel_f0, vec3(1.0), s_ior_table(s.rough, mu, z));
        // the energy-compensated lobe's albedo: E (1 + Fms (1 - E) / E) times the Fresnel mean
        l.diel_albedo = (s.multi ? E * l.diel_comp : vec3(1.0)) * albedo;
        l.diffuse = clamp(1.0 - max(max(l.diel_albedo.r, l.diel_albedo.g), l.diel_albedo.b), 0.0, 1.0);
    }
    return l;
}

// The surface's BSDF times the cosine toward L (Cycles' eval), for the view V, normal n.
vec3 surface_bsdf_cos(SurfacePoint s, Lobes l, vec3 n, vec3 V, vec3 L) {
    float ndl = dot(n, L);
    float ndv = dot(n, V);
    if (ndl <= 0.0 || s.weight <= 0.0) return vec3(0.0);
    float w_diel = s.weight * (1.0 - s.metal);
    vec3 f = s.base * (w_diel * l.diffuse * ndl / PI);
    if (ndv > 0.0 && l.alpha2 > 5e-7) {
        vec3 H = normalize(V + L);
        float nh = dot(n, H);
        float vh = dot(V, H);
        float d = 1.0 + (l.alpha2 - 1.0) * nh * nh;
        float D = l.alpha2 / (PI * d * d);
        float lv = 0.5 * (sqrt(1.0 + l.alpha2 * max(1.0 / (ndv * ndv) - 1.0, 0.0)) - 1.0);
        float ll = 0.5 * (sqrt(1.0 + l.alpha2 * max(1.0 / (ndl * ndl) - 1.0, 0.0)) - 1.0);
        float spec = D * 0.25 / ndv / (1.0 + lv + ll);
        if (s.metal > 0.0) {
            vec3 F = s.constant_fresnel ? l.metal_f0 : fresnel_f82(vh, l.metal_f0, l.metal_B);
            f += (s.weight * s.metal * spec) * F * l.metal_comp;
        }
        if (w_diel > 0.0 && abs(s.ior - 1.0) > 1e-5) {
            float sF = (fresnel_dielectric_cos(vh, s.ior) - l.diel_F0real) / max(1.0 - l.diel_F0real, 1e-6);
            vec3 F = mix(l.diel_f0, vec3(1.0), sF);
            f += (w_diel * spec) * F * l.diel_comp;
        }
    }
    return f;
}

// The surface's albedo toward V under light equal from every direction (the ambient term).
vec3 surface_albedo(SurfacePoint s, Lobes l) {
    float w_diel = s.weight * (1.0 - s.metal);
    return w_diel * (s.base * l.diffuse + l.diel_albedo) + s.weight * s.metal * l.metal_albedo;
}

// The shadow-map bias of a surface lit at cos_l, in texel footprints: 3, plus the surface's depth
// change across two texels (its slope, tan of the light's incidence), at most 60.
float surface_bias_texels(float cos_l) {
    float c = clamp(cos_l, 1e-3, 1.0);
    return 3.0 + min(2.0 * sqrt(1.0 - c * c) / c, 57.0);
}
