//! points.wgsl: how eval_patch.wgsl reads a target point's data where subgroup operations are
//! not available: every lane loads the point's vec4s itself. Spliced into eval_patch.wgsl at
//! its line `// @include points.wgsl`; on devices with subgroup operations
//! src/eval/gpu/mod.rs splices points_subgroup.wgsl there instead (the same items, faster on
//! lavapipe).

// The entry point's built-in inputs.
struct Ids {
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
}

// Target p.
fn fetch_target(ids: Ids, p: u32) -> Target {
    return target_of(points[6u * p], points[6u * p + 1u]);
}

// Target p and the reference's partials there.
fn fetch_point(ids: Ids, p: u32) -> PointData {
    let q = 6u * p;
    return PointData(
        target_of(points[q], points[q + 1u]),
        jet_of(points[q + 2u], points[q + 3u], points[q + 4u], points[q + 5u]),
    );
}
