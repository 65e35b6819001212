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
