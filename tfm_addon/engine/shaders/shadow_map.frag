#include "common.glsl"
in vec3 v_world;
out float o_distance;
void main() {
    o_distance = light_distance(light_space(v_world));
    gl_FragDepth = o_distance / u_shadow_far;
}
