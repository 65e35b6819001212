// The world's radiance seen behind everything (opaque film) by direction, where it varies: an
// equirectangular panorama with mipmaps (Cycles' mapping: u = 0.5 - atan2(y, x) / 2 pi,
// v = 1 - acos(z) / pi; passes/bindings.BackgroundTexture). Included by composite.frag with
// BACKGROUND_IMAGE, before compose.glsl, whose background() this one replaces (frame_plan: a frame
// whose world varies never composes in a light pass).
#ifndef BACKGROUND_GLSL
#define BACKGROUND_GLSL
#include "view.glsl"
uniform sampler2D u_background;

// The background toward window point ``frag``, read at the level of detail of the pixel's size.
vec3 background(vec2 frag) {
    vec3 d = view_direction(frag);
    vec2 uv = vec2(0.5 - atan(d.y, d.x) * 0.15915494, 1.0 - acos(clamp(d.z, -1.0, 1.0)) * 0.31830989);
    float texels = float(textureSize(u_background, 0).x) * 0.15915494;     // per radian
    float lod = u_ortho == 1 ? 0.0 : log2(max(u_pixel_size * texels, 1.0));
    return textureLod(u_background, uv, lod).rgb;
}
#endif
