// The solids seen by the camera: base colour and distance along the view ray; the normal
// (octahedral, two floats), roughness and metallic (packed in one float) and a hit flag (2 a
// holdout: no albedo, so no radiance, and the composite leaves its alpha open; 1 + 2 k a surface
// of material k, surface.glsl).
// A surface of alpha a < 1 is seen at a fraction a of the pixel's antialiasing samples (Cycles'
// stochastic transparency): the fragment is discarded where the pixel's number for this sample is
// at least a. The number is the pixel's point of the R2 sequence (neighbouring pixels spread evenly
// over [0, 1)), shifted by a hash of the triangle and by the sample's seed (the R1 sequence: the
// samples of a pixel spread evenly too).
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
float alpha_number() {
    uint v = uint(gl_PrimitiveID) * 1664525u + 1013904223u;
    v ^= v >> 16u;
    v *= 2246822519u;
    v ^= v >> 13u;
    float shift = float(v & 0xffffffu) / 16777216.0;
    return fract(dot(floor(gl_FragCoord.xy), vec2(0.7548777, 0.5698403)) + shift + u_alpha_seed);
}

void main() {
    bool holdout = abs(v_hit - 2.0) < 0.5;
    if (!holdout && alpha_number() >= u_material[4 * material_index(v_hit) + 3].w) discard;
    vec3 rel = v_world - u_camera_pos;
    float dist = u_ortho == 1 ? dot(rel, u_camera_forward) : length(rel);
    o_albedo_distance = vec4(holdout ? vec3(0.0) : v_albedo, dist);
    o_normal_hit = vec4(octahedral_encode(normalize(v_normal)), pack_rough_metal(v_rough_metal), v_hit);
}
