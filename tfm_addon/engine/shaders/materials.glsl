// The solids' material table (engine/surface.py Surface.entry), four vec4 per material; the
// G-buffer's hit flag 1 + 2 k names material k.
#define MAX_MATERIALS 128
layout(std140) uniform Materials {
    vec4 u_material[4 * MAX_MATERIALS];    // base, weight | rough, metal, ior, multi | tint, const F |
                                           // emission, alpha (base, rough and metal: from the G-buffer)
};

int material_index(float hit_flag) {
    return clamp(int(hit_flag + 0.5) / 2, 0, MAX_MATERIALS - 1);
}

// Whether the fragment of a surface (hit flag; a holdout, 2, always) with alpha a is kept: a
// surface of alpha below 1 covers a fraction a of the pixels (Cycles' stochastic transparency).
// The fragment's number is its pixel's point of the R2 sequence (neighbours spread evenly over
// [0, 1)), shifted by a hash of the triangle and by ``seed`` (a sample's point of the R1 sequence:
// the samples of a pixel spread evenly too); it is kept where the number is below a.
bool alpha_covers(float hit_flag, float seed) {
    if (abs(hit_flag - 2.0) < 0.5) return true;
    uint v = uint(gl_PrimitiveID) * 1664525u + 1013904223u;
    v ^= v >> 16u;
    v *= 2246822519u;
    v ^= v >> 13u;
    float shift = float(v & 0xffffffu) / 16777216.0;
    float number = fract(dot(floor(gl_FragCoord.xy), vec2(0.7548777, 0.5698403)) + shift + seed);
    return number < u_material[4 * material_index(hit_flag) + 3].w;
}
