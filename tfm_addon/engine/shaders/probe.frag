// Evaluates the transmittance from the light (as the camera passes see it) at given points:
// texel i of the output holds T at the point in texel i of u_points.
#include "common.glsl"
#include "transmittance.glsl"
uniform sampler2D u_points;      // RGB32F world positions, one row
out vec4 o_transmittance;
void main() {
    vec3 p = texelFetch(u_points, ivec2(gl_FragCoord.xy), 0).xyz;
    vec3 q = light_space(p);
    o_transmittance = vec4(light_transmittance(p, q, light_distance(q)), 1.0);
}
