// The combined image from the light passes' sums (compose.glsl).
// TOP_ROW_FIRST: rows written in the order an image is stored (read back without a flip).
// ACCUMULATE: the sample is added (blending ONE, ONE) into a frame's sums instead: the combined
// image, its square and, with PASSES, the three passes (surfaces already times transmittance).
#ifdef ACCUMULATE
#define SAMPLE_SUMS 1
#endif
#if BACKGROUND_IMAGE
#include "background.glsl"
#endif
#include "compose.glsl"
uniform sampler2D u_gb1;          // normal, hit (2 holdout, else odd: a solid)
uniform sampler2D u_scatter;
uniform sampler2D u_surface;
uniform sampler2D u_transmittance;
#ifndef ACCUMULATE
layout(location = 0) out vec4 o_combined;
#endif
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
#ifdef TOP_ROW_FIRST
    // The combined image is written upside down, so that its rows read back top row first.
    px.y = textureSize(u_transmittance, 0).y - 1 - px.y;
#endif
    vec3 t = texelFetch(u_transmittance, px, 0).rgb;
    vec3 scatter = texelFetch(u_scatter, px, 0).rgb;
    vec3 surface = texelFetch(u_surface, px, 0).rgb;
#ifdef ACCUMULATE
    add_to_sums(scatter, surface, t, texelFetch(u_gb1, px, 0).w, vec2(px) + 0.5);
#else
    o_combined = combined_pixel(scatter, surface, t, texelFetch(u_gb1, px, 0).w, vec2(px) + 0.5);
#endif
}
