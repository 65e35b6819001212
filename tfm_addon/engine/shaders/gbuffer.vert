in vec3 in_position;   // world, metres
in vec3 in_normal;     // world, the face's
in vec3 in_albedo;     // the surface's base colour
in float in_hit;       // the hit flag: 2 a holdout, 1 + 2 k a surface of material k (surface.glsl)
in vec2 in_rough_metal;
uniform mat4 u_camera_clip;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_albedo;
flat out float v_hit;
flat out vec2 v_rough_metal;
void main() {
    v_world = in_position;
    v_normal = in_normal;
    v_albedo = in_albedo;
    v_hit = in_hit;
    v_rough_metal = in_rough_metal;
    gl_Position = u_camera_clip * vec4(in_position, 1.0);
}
