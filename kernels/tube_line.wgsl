//! id: tube.line
//! target: tube
//! source: Heitz & Hill 2017, GPU Zen, Section 1.5.3 (Listing 1.5 + Listing 1.9, summed and clamped)
//! minv: full
//! uses: line

// Section 1.5.3, "Summing the Contributions": "we simply add I_disk1 + I_disk2 to I_line
// of Equation (1.6), and we clamp the sum to 1 as explained in Section 1.2.5". Read
// literally that adds the disks to I_line itself, which has the dimension 1/length (the
// disks are dimensionless); Section 1.2.5 clamps R·I_line (Eq. 1.10, Listing 1.5), so
// the sum is min(1, R·I_line + I_disk1 + I_disk2), as docs/methods.md states.
// The disks are Listing 1.9 (caps_point.wgsl) inlined under a name of its own, since a
// line method composed with this kernel may define anything but `method`.
fn tube_I_ltc_disks(p1: vec3<f32>, p2: vec3<f32>, R: f32) -> f32 {
    let A = PI * R * R;
    let wt = normalize(p2 - p1);
    let wp1 = normalize(p1);
    let wp2 = normalize(p2);
    let Idisks = A * (
        D(wp1) * max(0.0, dot(wt, wp1)) / dot(p1, p1) +
        D(wp2) * max(0.0, dot(-wt, wp2)) / dot(p2, p2));
    return Idisks;
}

fn method(scene: Scene) -> f32 {
    let R = scene.radius;
    return min(1.0, R * I_line(scene.p1, scene.p2) + tube_I_ltc_disks(scene.p1, scene.p2, R));
}
