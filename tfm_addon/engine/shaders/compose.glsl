// The combined pixel from the light passes' sums: scattered light plus the solids' radiance seen
// through the medium. Transparent film: alpha 1 on solids, else (background, holdouts) 1 - mean
// view transmittance. Opaque film: the world's radiance behind the medium, attenuated by it,
// where no solid is seen, and alpha 1 (holdouts keep their alpha, as in Cycles). Read by
// composite.frag, and by a lone light pass that composes its own image (scatter.frag COMPOSE).
uniform int u_film_transparent;
#ifndef BACKGROUND_GLSL
// A constant world (the composite pass includes background.glsl first where the world seen varies
// with the direction).
uniform vec3 u_world;             // the world's radiance seen behind everything (opaque film)
vec3 background(vec2 frag) {
    return u_world;
}
#endif

// scatter, the solids' radiance before the medium (surface), the view transmittance t, the
// G-buffer's hit flag (2 holdout, else odd: a solid) and the window point (pixels).
vec4 combined_pixel(vec3 scatter, vec3 surface, vec3 t, float hit_flag, vec2 frag) {
    vec3 rgb = scatter + t * surface;
    bool holdout = abs(hit_flag - 2.0) < 0.5;
    bool hit = hit_flag > 0.5 && !holdout;
    float alpha = hit ? 1.0 : 1.0 - (t.r + t.g + t.b) / 3.0;
    if (u_film_transparent == 0 && !holdout) {
        if (!hit) rgb += t * background(frag);
        alpha = 1.0;
    }
    return vec4(rgb, alpha);
}

// SAMPLE_SUMS 1: the shader adds a sample into a frame's sums (blending ONE, ONE;
// passes/accumulate.py): composite.frag with ACCUMULATE, or a lone light pass, scatter.frag with
// SUMS. Its outputs: the combined pixel, its square and, with PASSES, the three passes (the
// surfaces times the view transmittance).
#if defined(SAMPLE_SUMS) && SAMPLE_SUMS
layout(location = 0) out vec4 o_combined;
layout(location = 1) out vec4 o_square;
#if PASSES
layout(location = 2) out vec4 o_scatter;
layout(location = 3) out vec4 o_surface;
layout(location = 4) out vec4 o_transmittance;
#endif
void add_to_sums(vec3 scatter, vec3 surface, vec3 t, float hit_flag, vec2 frag) {
    o_combined = combined_pixel(scatter, surface, t, hit_flag, frag);
    o_square = o_combined * o_combined;
#if PASSES
    o_scatter = vec4(scatter, 0.0);
    o_surface = vec4(t * surface, 0.0);
    o_transmittance = vec4(t, 0.0);
#endif
}
#endif
