// The solids seen by the camera: base colour and distance along the view ray; the normal
// (octahedral, two floats), roughness and metallic (packed in one float) and a hit flag (2 a
// holdout: no albedo, so no radiance, and the composite leaves its alpha open; 1 + 2 k a surface
// of material k, surface.glsl).
// A surface of alpha a < 1 is seen at a fraction a of the pixel's antialiasing samples (Cycles'
// stochastic transparency; materials.glsl alpha_covers, with the sample's seed).
#include "gbuffer_pack.glsl"
#include "materials.glsl"
uniform float u_alpha_seed;
uniform vec3 u_camera_pos;
uniform vec3 u_camera_forward;
uniform int u_ortho;
in vec3 v_world;
in vec3 v_normal;
in vec3 v_albedo;
flat in float v_hit;
flat in vec2 v_rough_metal;
layout(location = 0) out vec4 o_albedo_distance;
layout(location = 1) out vec4 o_normal_hit;
void main() {
    bool holdout = abs(v_hit - 2.0) < 0.5;
    if (!alpha_covers(v_hit, u_alpha_seed)) discard;
    vec3 rel = v_world - u_camera_pos;
    float dist = u_ortho == 1 ? dot(rel, u_camera_forward) : length(rel);
    o_albedo_distance = vec4(holdout ? vec3(0.0) : v_albedo, dist);
    o_normal_hit = vec4(octahedral_encode(normalize(v_normal)), pack_rough_metal(v_rough_metal), v_hit);
}
