in vec3 in_position;   // world, metres
in vec3 in_normal;     // world, the face's
in vec3 in_albedo;
uniform mat4 u_camera_clip;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_albedo;
void main() {
    v_world = in_position;
    v_normal = in_normal;
    v_albedo = in_albedo;
    gl_Position = u_camera_clip * vec4(in_position, 1.0);
}
