// The medium's own light (EMISSION) and per-voxel scattering colour (COLOR_GRID), as Cycles'
// Principled Volume defines them: emission is not scaled by density; the blackbody term is
// evaluated per voxel on the CPU (engine/blackbody.py). EMISSION 1: a constant, 2: read from grids,
// 3: from grids plus a constant part (passes/emission.AttributesGPU.program_kind).
// PACKED_DENSITY (AttributesGPU.packing): the first medium's density is read from the texture
// whose values the sample reads anyway, one fetch instead of two: 1 u_attrs' r (beside the grids'
// combined emission in gba), 3 u_color_grid's a; 0 u_density.
#if EMISSION
uniform sampler3D u_attrs;       // up to four attribute grids (padded like the density), or 1 voxel
uniform vec3 u_attrs_size;       // padded texture size, voxels
uniform vec3 u_bb_tint;
uniform vec3 u_emission_const;   // the parts that read no grid: colour x strength, tint x blackbody
uniform vec3 u_emit_lo;          // index-space box outside which nothing emits
uniform vec3 u_emit_hi;

// Part (t_in, t_out) of the ray ob + db t (box space) where the medium can emit.
vec2 emission_interval(vec3 ob, vec3 db) {
    vec3 inv = 1.0 / mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
    vec3 t0 = (u_emit_lo - ob) * inv;
    vec3 t1 = (u_emit_hi - ob) * inv;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    return vec2(max(max(lo.x, lo.y), lo.z), min(min(hi.x, hi.y), hi.z));
}

// Emitted radiance per metre for the attribute values a (grid channels). EMISSION_GRIDS (4: the
// emission of a strength grid, a blackbody grid or both, combined in gba, 8: a blackbody intensity
// grid in r times the term at intensity 1 in gba) is fixed with the attribute texture; the parts that read no grid come summed in one uniform
// (passes/emission.AttributesGPU.bind).
vec3 emission_of(vec4 a) {
#if EMISSION == 2 || GLOW_BLOCKS
    vec3 e = vec3(0.0);     // no part that reads no grid (AttributesGPU.program_kind), or one the
                            // march adds where the glow blocks say (glow_at)
#else
    vec3 e = u_emission_const;
#endif
#if EMISSION_GRIDS & 4
    e += a.gba;             // the grids' emission, combined per voxel (AttributesGPU.combine)
#endif
#if EMISSION_GRIDS & 8
    e += u_bb_tint * (a.r * a.gba);     // an intensity grid's blend times the term's (medium_attributes)
#endif
    return e;
}

#if GLOW_BLOCKS
// The blocks of the grid's index space where the constant part glows (scene.GlowBlocks: Cycles'
// volume mesh): 1 in one, else 0.
uniform sampler3D u_glow;
uniform vec3 u_glow_origin;
uniform vec3 u_glow_side;
float glow_at(vec3 idx) {
    ivec3 b = ivec3(floor((idx - u_glow_origin) / u_glow_side));
    if (any(lessThan(b, ivec3(0))) || any(greaterThanEqual(b, textureSize(u_glow, 0)))) return 0.0;
    return texelFetch(u_glow, b, 0).r;
}

// Where the ray ob + db t (grid index space) leaves the glow block holding its point at t.
float glow_exit(vec3 ob, vec3 db, float t) {
    vec3 b = floor((ob + db * t - u_glow_origin) / u_glow_side);
    db = mix(db, vec3(1e-12), lessThan(abs(db), vec3(1e-12)));
    vec3 tb = (u_glow_origin + (b + step(0.0, db)) * u_glow_side - ob) / db;
    return max(t, min(min(tb.x, tb.y), tb.z));
}
#endif

// Emitted radiance per metre at a point in box (grid index) space.
vec3 emission_at_index(vec3 idx) {
#if EMISSION >= 2
    return emission_of(texture(u_attrs, (idx + 1.5) / u_attrs_size));
#else
    return emission_of(vec4(0.0));      // a constant emission reads no grid
#endif
}

// Emitted radiance per metre where no grid emits: in the cells u_occupancy's G channel leaves 0
// (passes/emission), or everywhere for a constant emission.
vec3 emission_constant() {
    return emission_of(vec4(0.0));
}

// How many of the march's samples k in [k_lo, k_hi), at t = t0 + (k + at) dt, lie in [e.x, e.y].
int samples_within(vec2 e, int k_lo, int k_hi, float t0, float dt, float at) {
    float lo = clamp(ceil((e.x - t0) / dt - at), float(k_lo), float(k_hi));
    float hi = clamp(floor((e.y - t0) / dt - at) + 1.0, lo, float(k_hi));
    return int(hi - lo);
}
#endif

#if COLOR_GRID
uniform sampler3D u_color_grid;  // RGB per voxel (A: the density, PACKED_DENSITY 3), padded like it

vec3 color_at_index(vec3 idx) {
    return texture(u_color_grid, (idx + 1.5) / u_grid_size).rgb;
}
#endif

#if PACKED_DENSITY
// The packed texture and its padded size: the march steps its coordinates along the ray,
// (ob + db t + 1.5) / PACKED_SIZE in the first medium's index space.
#if PACKED_DENSITY == 3
#define PACKED_SIZE u_grid_size
#else
#define PACKED_SIZE u_attrs_size
#endif
vec4 packed_fetch(vec3 tc) {
#if PACKED_DENSITY == 3
    return textureLod(u_color_grid, tc, 0.0);
#else
    return textureLod(u_attrs, tc, 0.0);
#endif
}

// The first medium's density from its packed values pk: medium_density(0, p) of common.glsl,
// without its box test (outside the density's non-zero bounds its trilinear values are 0, as
// the lone grid's march in scatter.frag relies on).
float packed_density(vec4 pk) {
    return pk[PACKED_DENSITY == 1 ? 0 : 3] * u_grid_scales[0];
}
#endif
