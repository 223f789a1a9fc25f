// The GLSL prelude of a GLSL kernel (src/glsl.rs): the same scene, constants and helpers as
// kernels/prelude.wgsl, under the same names, so the translated kernel runs on the WGSL
// prelude. Only declarations, which the translation drops again; the kernel's code follows.
#version 450

const float PI = 3.14159265358979323846;

struct Scene {
    vec3 p1;
    float radius;
    vec3 p2;
    float rect_width;
    vec3 rect_normal;
    uint flags;
    mat3 minv;
    // The ggx material, in this scene's frame; 0 otherwise (prelude.wgsl).
    vec3 view;
    float alpha_x;
    vec3 tangent;
    float alpha_y;
    // Contract 3: Fresnel and the textured emitter (prelude.wgsl).
    vec3 tex_origin;
    float f0;
    uint tex_kind;
    uint tex_offset;
    uint tex_nu;
    uint tex_nv;
};

const uint FLAG_LTC = 1u;
const uint FLAG_RADIUS = 2u;
const uint FLAG_RECT = 4u;

mat3 Minv;

// Prototypes only: the translation keeps the calls and drops these, and the WGSL prelude's
// definitions run (one source for each helper).
float D(vec3 w);
void buildOrthonormalBasis(vec3 n, out vec3 b1, out vec3 b2);
mat3 inverse3(mat3 m);
// A light texture's bilinear look-up in the harness's texel buffer.
float ll_texel_bilinear(uint base, uint nu, uint nv, float u, float v, bool wrap_v);
float ll_texel_cube(uint base, uint n, vec3 w);
// For a `//! uses: line` kernel: the line method chosen at run time (kernels/README.md).
float I_line(vec3 p1, vec3 p2);
