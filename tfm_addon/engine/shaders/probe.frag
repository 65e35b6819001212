// Evaluates a light face at given points, as the camera passes see it: texel (x, y) of the output
// holds the value at the point in texel (x, y) of u_points. PROBE 0: the transmittance from the
// light; 1: the light arriving there (its radiance past the solids and the media, W/m² for a
// sun, W/(sr m²)... as light_arriving); 2: the irradiance of a surface there whose unit normal is
// in u_normals (the light arriving times the cosine, the solids' shadow biased as a lit surface's);
// 3: the light the media scatter there, times 4 pi (the octaves of the multiple scattering,
// octaves.glsl, summed with the phase function's mean: the world field's light, which comes from
// every side), the media's albedo there in u_normals.
#ifndef PROBE
#define PROBE 0
#endif
#if PROBE == 3
#define HAS_LIGHT 1
#endif
#include "common.glsl"
#include "transmittance.glsl"
#include "octaves.glsl"
#include "light_reaching.glsl"
uniform sampler2D u_points;      // RGB32F world positions
uniform sampler2D u_normals;     // RGB32F unit normals (PROBE 2), albedos (PROBE 3)
out vec4 o_value;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 p = texelFetch(u_points, px, 0).xyz;
    vec3 q = light_space(p);
    float r = light_distance(q);
#if PROBE == 0
    o_value = vec4(light_transmittance(p, q, r), 1.0);
#elif PROBE == 1
    o_value = vec4(light_arriving(p, q, r), 1.0);
#elif PROBE == 3
    vec3 t_light;
    vec3 li = light_reaching(p, q, r, t_light);
    vec3 albedo = texelFetch(u_normals, px, 0).xyz;
    vec3 s = octave_phase(t_light, light_through(p, q, r, t_light), vec3(0.0), 1.0, 0.0, albedo);
    o_value = vec4(li * s * (4.0 * PI), 1.0);
#else
    vec3 n = texelFetch(u_normals, px, 0).xyz;
    float c = dot(n, toward_light(p, q, r));
    g_bias_texels = 3.0;        // the surface's own texels must not shadow it
    o_value = vec4(c > 0.0 ? light_arriving(p, q, r) * c : vec3(0.0), 1.0);
#endif
}
