in vec3 in_position;   // world, metres
uniform mat4 u_light_clip;
out vec3 v_world;
void main() {
    v_world = in_position;
    gl_Position = u_light_clip * vec4(in_position, 1.0);
}
