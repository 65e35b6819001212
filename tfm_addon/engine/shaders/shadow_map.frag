#include "common.glsl"
in vec3 v_world;
out float o_distance;
void main() {
    o_distance = length(v_world - u_light_pos);
    gl_FragDepth = o_distance / u_shadow_far;
}
