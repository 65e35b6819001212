in vec3 in_position;   // world, metres
in float in_hit;       // the hit flag (gbuffer.vert): names the material, whose alpha the map reads
uniform mat4 u_light_clip;
out vec3 v_world;
flat out float v_hit;
void main() {
    v_world = in_position;
    v_hit = in_hit;
    gl_Position = u_light_clip * vec4(in_position, 1.0);
}
