// The light an emitting medium casts on the solids (engine/fire_light.py): a few dozen points of
// its emission, each with the medium's transmittance outwards by direction (an octahedral map,
// the points' maps side by side in u_fire). Unshadowed by solids.
#if FIRE_LIGHT
#define MAX_FIRE 64
uniform sampler2D u_fire;
uniform int u_fire_count;
uniform vec2 u_fire_atlas;          // the maps' texture size, texels
uniform vec4 u_fire_pos[MAX_FIRE];  // position (m), softening radius² (m²)
uniform vec4 u_fire_power[MAX_FIRE];  // intensity, W/sr
uniform mat3 u_fire_to_local;       // world directions to the maps' frame (the medium's rotation)

vec2 octahedral(vec3 d) {
    vec2 p = d.xy / (abs(d.x) + abs(d.y) + abs(d.z));
    if (d.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    return p * 0.5 + 0.5;
}

// Irradiance (W/m²) at P with unit normal n from the medium's emission.
vec3 fire_irradiance(vec3 P, vec3 n) {
    vec3 e = vec3(0.0);
    float side = u_fire_atlas.y;
    for (int i = 0; i < u_fire_count; ++i) {
        vec3 v = u_fire_pos[i].xyz - P;
        float r2 = dot(v, v);
        float r = sqrt(r2);
        float cosine = dot(n, v) / r;
        if (cosine <= 0.0) continue;
        vec2 uv = clamp(octahedral(u_fire_to_local * (-v / r)) * side, vec2(0.5), vec2(side - 0.5));
        uv.x += side * float(i);
        vec3 t = texture(u_fire, uv / u_fire_atlas).rgb;
        e += u_fire_power[i].rgb * (cosine / (r2 + u_fire_pos[i].w)) * t;
    }
    return e;
}
#endif
