// Seed 002's horizon handling (Tt Games, "Line lights"), operation for operation, shared by
// the MRP kernels of kernels/mrp/: "If points are on opposite sides, guaranteed
// intersection": "limit the points A or B (depending on the case)" to where the segment
// crosses the surface's plane z = 0 (P, the shading point, is the origin).
// Statements, not a function: included inside a function body with `p1`, `p2` in scope
// (`#include "lib/mrp_horizon.wgsl"`), it declares `A`, `B` (the clipped ends), `PA`, `PB`
// (the same, from P) and `AB` as the listing does, so that each kernel goes on with the
// listing's own names and operations.
    var A = p1;
    var B = p2;
    var PA = A;
    var PB = B;
    var AB = B - A;
    let N = vec3<f32>(0.0, 0.0, 1.0);
    if ((dot(PA, N) > 0.0) != (dot(PB, N) > 0.0)) {
        let t = -dot(PA, N) / dot(AB, N);
        let intersectionPoint = A + t * AB;
        if (dot(PA, N) > 0.0) {
            B = intersectionPoint;
            PB = B;
        } else {
            A = intersectionPoint;
            PA = A;
        }
        AB = B - A;
    }
