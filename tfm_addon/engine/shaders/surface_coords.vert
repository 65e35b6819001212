in vec3 in_position;   // world, metres
in vec3 in_object;     // the same point in the object's space
in vec2 in_uv;
uniform mat4 u_camera_clip;
out vec3 v_object;
out vec2 v_uv;
void main() {
    v_object = in_object;
    v_uv = in_uv;
    gl_Position = u_camera_clip * vec4(in_position, 1.0);
}
