// A surface of alpha a < 1 covers a fraction a of the map's texels (materials.glsl alpha_covers):
// the light passes' filtered look-ups (2x2 comparison, soft-shadow taps) average it into the
// (1 - a) of the light that Cycles' transparent shadows let through.
#include "common.glsl"
#include "materials.glsl"
in vec3 v_world;
flat in float v_hit;
out float o_distance;
void main() {
    if (!alpha_covers(v_hit, 0.0)) discard;
    o_distance = light_distance(light_space(v_world));
    gl_FragDepth = o_distance / u_shadow_far;
}
