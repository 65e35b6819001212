// A surface of alpha a < 1 covers a fraction a of the map's texels (the texel's point of the R2
// sequence, shifted by a hash of the triangle): the light passes' filtered look-ups and the
// antialiasing samples average it into the (1 - a) of the light that Cycles lets through.
#include "common.glsl"
#include "materials.glsl"
in vec3 v_world;
flat in float v_hit;
out float o_distance;
void main() {
    uint v = uint(gl_PrimitiveID) * 1664525u + 1013904223u;
    v ^= v >> 16u;
    v *= 2246822519u;
    v ^= v >> 13u;
    float shift = float(v & 0xffffffu) / 16777216.0;
    float number = fract(dot(floor(gl_FragCoord.xy), vec2(0.7548777, 0.5698403)) + shift);
    if (abs(v_hit - 2.0) > 0.5 && number >= u_material[4 * material_index(v_hit) + 3].w) discard;
    o_distance = light_distance(light_space(v_world));
    gl_FragDepth = o_distance / u_shadow_far;
}
