// The HLSL prelude of an HLSL kernel (src/kernel/hlsl.rs): the same scene, constants and
// helpers as kernels/prelude.wgsl, under the same names, so the translated kernel runs on the
// WGSL prelude. glslang's HLSL front end compiles prelude + kernel + a small entry point to
// SPIR-V; the translation drops these declarations again and the WGSL prelude's run.

static const float PI = 3.14159265358979323846;

struct Scene {
    float3 p1;
    float radius;
    float3 p2;
    float rect_width;
    float3 rect_normal;
    uint flags;
    // Row-major: minv[i] is row i of M⁻¹ and mul(minv, v) is M⁻¹·v, as written.
    row_major float3x3 minv;
    // The ggx material, in this scene's frame; 0 otherwise (prelude.wgsl).
    float3 view;
    float alpha_x;
    float3 tangent;
    float alpha_y;
    // Contract 3: Fresnel and the textured emitter (prelude.wgsl).
    float3 tex_origin;
    float f0;
    uint tex_kind;
    uint tex_offset;
    uint tex_nu;
    uint tex_nv;
};

static const uint FLAG_LTC = 1u;
static const uint FLAG_RADIUS = 2u;
static const uint FLAG_RECT = 4u;

// The listings' global M⁻¹, row-major as the scene's: mul(Minv, v) is M⁻¹·v.
static row_major float3x3 Minv;

// Stand-ins only: glslang needs bodies, the translation drops them and the WGSL prelude's
// definitions run (one source for each helper). Their values here are never used.
float D(float3 w) { return 0.0; }
void buildOrthonormalBasis(float3 n, out float3 b1, out float3 b2) { b1 = n; b2 = n; }
float3x3 inverse3(float3x3 m) { return m; }
// A light texture's bilinear look-up in the harness's texel buffer.
float ll_texel_bilinear(uint base, uint nu, uint nv, float u, float v, bool wrap_v) { return 0.0; }
float ll_texel_cube(uint base, uint n, float3 w) { return 0.0; }
// For a `//! uses: line` kernel: the line method chosen at run time (kernels/README.md).
float I_line(float3 p1, float3 p2) { return 0.0; }
