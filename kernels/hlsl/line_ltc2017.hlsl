//! id: line.ltc2017_hlsl
//! target: line
//! source: Heitz & Hill 2017, GPU Zen, Listings 1.6 + 1.7, in HLSL as an engine ships it
//! minv: full

// An HLSL kernel (src/kernel/hlsl.rs): Listings 1.6 + 1.7 as an engine writes them in HLSL,
// ported from the listing's GLSL: vec3 is float3, `Minv * p` is mul(Minv, p), `l` for the
// digit 1 the PDF shows (see kernels/line_ltc2017.wgsl). HLSL has no inverse(); the
// prelude's inverse3 stands in, as in the WGSL port. tests/hlsl.rs checks it against the
// WGSL port and the reference.

float Fpo(float d, float l)
{
    return l/(d*(d*d + l*l)) + atan(l/d)/(d*d);
}

float Fwt(float d, float l)
{
    return l*l/(d*(d*d + l*l));
}

float I_diffuse_line(float3 p1, float3 p2)
{
    // tangent
    float3 wt = normalize(p2 - p1);

    // clamping
    if (p1.z <= 0.0 && p2.z <= 0.0) return 0.0;
    if (p1.z < 0.0) p1 = (+p1*p2.z - p2*p1.z) / (+p2.z - p1.z);
    if (p2.z < 0.0) p2 = (-p1*p2.z + p2*p1.z) / (-p2.z + p1.z);

    // parameterization
    float l1 = dot(p1, wt);
    float l2 = dot(p2, wt);

    // shading point orthonormal projection on the line
    float3 po = p1 - l1*wt;

    // distance to line
    float d = length(po);

    // integral
    float I = (Fpo(d, l2) - Fpo(d, l1)) * po.z +
              (Fwt(d, l2) - Fwt(d, l1)) * wt.z;
    return I / PI;
}

float I_ltc_line(float3 p1, float3 p2)
{
    // transform to diffuse configuration
    float3 p1o = mul(Minv, p1);
    float3 p2o = mul(Minv, p2);
    float I_diffuse = I_diffuse_line(p1o, p2o);

    // width factor
    float3 ortho = normalize(cross(p1, p2));
    float w = 1.0 / length(mul(inverse3(transpose(Minv)), ortho));

    return w * I_diffuse;
}

float method(Scene scene)
{
    return I_ltc_line(scene.p1, scene.p2);
}
