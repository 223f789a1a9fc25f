//! id: line.ltc2017_glsl
//! target: line
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7, in the listings' own language (GLSL)
//! minv: full

// A GLSL kernel (src/glsl.rs): the same listing as kernels/line_ltc2017.wgsl, written in GLSL
// as published, `l` for the digit 1 the PDF shows (see that file). GLSL `inverse` has no WGSL
// form, so the prelude's `inverse3` stands in, as in the WGSL port. tests/glsl.rs checks that
// it agrees with the WGSL port to f32 rounding.

float Fpo(float d, float l) {
    return l / (d * (d * d + l * l)) + atan(l / d) / (d * d);
}

float Fwt(float d, float l) {
    return l * l / (d * (d * d + l * l));
}

float I_diffuse_line(vec3 p1, vec3 p2) {
    // tangent
    vec3 wt = normalize(p2 - p1);

    // clamping
    if (p1.z <= 0.0 && p2.z <= 0.0) return 0.0;
    if (p1.z < 0.0) p1 = (p1 * p2.z - p2 * p1.z) / (p2.z - p1.z);
    if (p2.z < 0.0) p2 = (-p1 * p2.z + p2 * p1.z) / (-p2.z + p1.z);

    // parameterization
    float l1 = dot(p1, wt);
    float l2 = dot(p2, wt);

    // shading point orthonormal projection on the line
    vec3 po = p1 - l1 * wt;

    // distance to line
    float d = length(po);

    // integral
    float I = (Fpo(d, l2) - Fpo(d, l1)) * po.z + (Fwt(d, l2) - Fwt(d, l1)) * wt.z;
    return I / PI;
}

float I_ltc_line(vec3 p1, vec3 p2) {
    // transform to diffuse configuration
    vec3 p1o = Minv * p1;
    vec3 p2o = Minv * p2;
    float I_diffuse = I_diffuse_line(p1o, p2o);

    // width factor
    vec3 ortho = normalize(cross(p1, p2));
    float w = 1.0 / length(inverse3(transpose(Minv)) * ortho);

    return w * I_diffuse;
}

float method(Scene scene) {
    return I_ltc_line(scene.p1, scene.p2);
}
