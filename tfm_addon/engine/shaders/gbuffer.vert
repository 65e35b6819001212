in vec3 in_position;   // world, metres
in vec3 in_normal;     // world, the face's
in vec3 in_albedo;
in float in_holdout;   // 1 for a holdout mesh
uniform mat4 u_camera_clip;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_albedo;
flat out float v_holdout;
void main() {
    v_world = in_position;
    v_normal = in_normal;
    v_albedo = in_albedo;
    v_holdout = in_holdout;
    gl_Position = u_camera_clip * vec4(in_position, 1.0);
}
