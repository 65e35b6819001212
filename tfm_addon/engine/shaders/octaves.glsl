// Multiple scattering as octaves of the single scattering (engine/multiple_scattering.py;
// Wrenninge et al. 2013): octave n sees the light's transmittance T^(a^n), adds (b albedo)^n of
// its light and scatters with anisotropy g c^n. OCTAVES 1 (or undefined) is single scattering.
#ifndef OCTAVES
#define OCTAVES 1
#endif
uniform vec3 u_octave;     // a, b, c

// The octaves' sum of contribution x light transmittance x phase at one sample: with one octave
// T hg(cos_theta, g). t_light: the media's transmittance from the light; albedo: the medium's
// sigma_s / sigma_t there.
vec3 octave_phase(vec3 t_light, float cos_theta, float g, vec3 albedo) {
    vec3 s = t_light * hg_phase(cos_theta, g);
#if OCTAVES > 1
    vec3 log_t = log2(max(t_light, vec3(1e-30)));
    vec3 step_b = u_octave.y * clamp(albedo, 0.0, 1.0);
    float an = 1.0;
    vec3 bn = vec3(1.0);
    float gn = g;
    for (int n = 1; n < OCTAVES; ++n) {
        an *= u_octave.x;
        bn *= step_b;
        gn *= u_octave.z;
        s += bn * exp2(an * log_t) * hg_phase(cos_theta, gn);
    }
#endif
    return s;
}
