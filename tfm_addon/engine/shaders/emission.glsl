// The medium's own light (EMISSION) and per-voxel scattering colour (COLOR_GRID), as Cycles'
// Principled Volume defines them: emission is not scaled by density.
#if EMISSION
uniform sampler3D u_attrs;       // up to four attribute grids (padded like the density), or 1 voxel
uniform vec3 u_attrs_size;       // padded texture size, voxels
uniform vec3 u_emission_color;   // W/(sr m^2) per metre per unit strength
uniform vec3 u_strength;         // scale, offset, channel of u_attrs (-1: constant)
uniform vec3 u_bb_intensity;     // the same for Blackbody Intensity
uniform vec3 u_temperature;      // the same for the temperature, kelvin
uniform vec3 u_bb_tint;

float attr_value(vec3 e, vec4 a) {
    int c = int(e.z);
    return c < 0 ? e.y : e.x * max(a[c], 0.0) + e.y;
}

// Cycles' fit of the blackbody colour in Rec.709 (intern/cycles/kernel/tables.h).
vec3 blackbody_rec709(float t) {
    if (t >= 12000.0) return vec3(0.8262954810464208, 0.9945080501520986, 1.566307710274283);
    if (t < 800.0) return vec3(5.413294490189271, -0.20319390035873933, -0.0822535242887164);
    vec3 R[7] = vec3[7](vec3(1.61919106e+03, -2.05010916e-03, 5.02995757e+00),
                        vec3(2.48845471e+03, -1.11330907e-03, 3.22621544e+00),
                        vec3(3.34143193e+03, -4.86551192e-04, 1.76486769e+00),
                        vec3(4.09461742e+03, -1.27446582e-04, 7.25731635e-01),
                        vec3(4.67028036e+03, 2.91258199e-05, 1.26703442e-01),
                        vec3(4.59509185e+03, 2.87495649e-05, 1.50345020e-01),
                        vec3(3.78717450e+03, 9.35907826e-06, 3.99075871e-01));
    vec3 G[7] = vec3[7](vec3(-4.88999748e+02, 6.04330754e-04, -7.55807526e-02),
                        vec3(-7.55994277e+02, 3.16730098e-04, 4.78306139e-01),
                        vec3(-1.02363977e+03, 1.20223470e-04, 9.36662319e-01),
                        vec3(-1.26571316e+03, 4.87340896e-06, 1.27054498e+00),
                        vec3(-1.42529332e+03, -4.01150431e-05, 1.43972784e+00),
                        vec3(-1.17554822e+03, -2.16378048e-05, 1.30408023e+00),
                        vec3(-5.00799571e+02, -4.59832026e-06, 1.09098763e+00));
    vec4 B[7] = vec4[7](vec4(5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03),
                        vec4(2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02),
                        vec4(-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02),
                        vec4(-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01),
                        vec4(-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02),
                        vec4(-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01),
                        vec4(6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01));
    int i = t >= 6365.0 ? 6 : t >= 3315.0 ? 5 : t >= 1902.0 ? 4 : t >= 1449.0 ? 3
          : t >= 1167.0 ? 2 : t >= 965.0 ? 1 : 0;
    vec3 r = R[i];
    vec3 g = G[i];
    vec4 b = B[i];
    return vec3(r.x / t + r.y * t + r.z, g.x / t + g.y * t + g.z, ((b.x * t + b.y) * t + b.z) * t + b.w);
}

// Emitted radiance per metre at a point in box (grid index) space.
vec3 emission_at_index(vec3 idx) {
    vec4 a = texture(u_attrs, (idx + 1.5) / u_attrs_size);
    vec3 e = u_emission_color * max(attr_value(u_strength, a), 0.0);
    float bb = attr_value(u_bb_intensity, a);
    if (bb > 0.0) {
        float T = max(attr_value(u_temperature, a), 0.0);
        float T2 = T * T;
        e += u_bb_tint * (5.670373e-14 / PI) * mix(1.0, T2 * T2, bb) * blackbody_rec709(T);
    }
    return e;
}
#endif

#if COLOR_GRID
uniform sampler3D u_color_grid;  // RGB per voxel, padded like the density

vec3 color_at_index(vec3 idx) {
    return texture(u_color_grid, (idx + 1.5) / u_grid_size).rgb;
}
#endif
