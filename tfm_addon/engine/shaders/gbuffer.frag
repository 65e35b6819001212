// The solids seen by the camera: albedo and distance along the view ray; normal and a hit flag
// (1 a solid, 2 a holdout: no albedo, so no radiance, and the composite leaves its alpha open).
uniform vec3 u_camera_pos;
uniform vec3 u_camera_forward;
uniform int u_ortho;
in vec3 v_world;
in vec3 v_normal;
in vec3 v_albedo;
flat in float v_holdout;
layout(location = 0) out vec4 o_albedo_distance;
layout(location = 1) out vec4 o_normal_hit;
void main() {
    vec3 rel = v_world - u_camera_pos;
    float dist = u_ortho == 1 ? dot(rel, u_camera_forward) : length(rel);
    bool holdout = v_holdout > 0.5;
    o_albedo_distance = vec4(holdout ? vec3(0.0) : v_albedo, dist);
    o_normal_hit = vec4(normalize(v_normal), holdout ? 2.0 : 1.0);
}
