//! id: cylinder.line_glsl
//! target: cylinder
//! source: Heitz & Hill 2017, GPU Zen, Listing 1.5, in GLSL
//! minv: full
//! uses: line

// A GLSL composite (src/glsl.rs): Listing 1.5 as kernels/cylinder_line.wgsl ports it, calling
// the prelude's `I_line`, which the harness supplies from any line method at run time.

float I_cylinder_approx(vec3 p1, vec3 p2, float R) {
    return min(1.0, R * I_line(p1, p2));
}

float method(Scene scene) {
    return I_cylinder_approx(scene.p1, scene.p2, scene.radius);
}
