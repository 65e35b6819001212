// The combined image from the light passes' sums: scattered light plus the solids' radiance
// seen through the medium. Transparent film: alpha 1 on solids, else (background, holdouts)
// 1 - mean view transmittance. Opaque film: the world's radiance behind the medium, attenuated
// by it, where no solid is seen, and alpha 1 (holdouts keep their alpha, as in Cycles).
// ACCUMULATE: the sample is added (blending ONE, ONE) into a frame's sums instead: the combined
// image, its square and, with PASSES, the three passes (surfaces already times transmittance).
uniform sampler2D u_gb1;          // normal, hit (1 solid, 2 holdout)
uniform sampler2D u_scatter;
uniform sampler2D u_surface;
uniform sampler2D u_transmittance;
uniform int u_film_transparent;
uniform vec3 u_world;             // radiance seen behind everything (opaque film)
layout(location = 0) out vec4 o_combined;
#ifdef ACCUMULATE
layout(location = 1) out vec4 o_square;
#if PASSES
layout(location = 2) out vec4 o_scatter;
layout(location = 3) out vec4 o_surface;
layout(location = 4) out vec4 o_transmittance;
#endif
#endif
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 t = texelFetch(u_transmittance, px, 0).rgb;
    vec3 scatter = texelFetch(u_scatter, px, 0).rgb;
    vec3 surface = t * texelFetch(u_surface, px, 0).rgb;
    vec3 rgb = scatter + surface;
    float hit_flag = texelFetch(u_gb1, px, 0).w;
    bool hit = hit_flag > 0.5 && hit_flag < 1.5;
    bool holdout = hit_flag > 1.5;
    float alpha = hit ? 1.0 : 1.0 - (t.r + t.g + t.b) / 3.0;
    if (u_film_transparent == 0 && !holdout) {
        if (!hit) rgb += t * u_world;
        alpha = 1.0;
    }
    o_combined = vec4(rgb, alpha);
#ifdef ACCUMULATE
    o_square = o_combined * o_combined;
#if PASSES
    o_scatter = vec4(scatter, 0.0);
    o_surface = vec4(surface, 0.0);
    o_transmittance = vec4(t, 0.0);
#endif
#endif
}
