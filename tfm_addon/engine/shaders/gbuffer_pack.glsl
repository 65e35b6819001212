// The G-buffer's second target: (octahedral normal x, y; roughness and metallic; hit flag).
// Roughness and metallic are 12-bit steps packed into one float (exact below 2^24).

vec2 octahedral_encode(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 p = n.xy;
    if (n.z < 0.0) p = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return p;
}

vec3 octahedral_decode(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return normalize(n);
}

float pack_rough_metal(vec2 rm) {
    vec2 q = floor(clamp(rm, 0.0, 1.0) * 4095.0 + 0.5);
    return q.x + 4096.0 * q.y;
}

vec2 unpack_rough_metal(float v) {
    float m = floor(v / 4096.0);
    return vec2(v - 4096.0 * m, m) / 4095.0;
}
