//! points_subgroup.wgsl: how eval_patch.wgsl reads a target point's data on devices with
//! subgroup operations (the host enables them where the adapter has them, and splices this
//! file in at `// @include points.wgsl` instead of points.wgsl).
//!
//! Every lane of a subgroup reads the same point, so lane l loads vec4 l of it alone and the
//! others take it with a broadcast: one load instruction a point instead of one a vec4. On
//! lavapipe, which loads from storage buffers lane by lane even where every lane reads the
//! same address, that is most of the cost of reading the point (see eval_patch.wgsl).
//! Subgroups narrower than the point read it as points.wgsl does. The broadcasts need all
//! lanes of the subgroup active, as they are: eval_patch.wgsl's point loops do not diverge.

// The entry point's built-in inputs.
struct Ids {
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
    @builtin(subgroup_invocation_id) sid: u32,
    @builtin(subgroup_size) size: u32,
}

// Target p.
fn fetch_target(ids: Ids, p: u32) -> Target {
    if (ids.size < 2u) {
        return target_of(points[6u * p], points[6u * p + 1u]);
    }
    let mine = points[6u * p + min(ids.sid, 1u)];
    return target_of(subgroupBroadcast(mine, 0u), subgroupBroadcast(mine, 1u));
}

// Target p and the reference's partials there.
fn fetch_point(ids: Ids, p: u32) -> PointData {
    let q = 6u * p;
    if (ids.size < 6u) {
        return PointData(
            target_of(points[q], points[q + 1u]),
            jet_of(points[q + 2u], points[q + 3u], points[q + 4u], points[q + 5u]),
        );
    }
    let mine = points[q + min(ids.sid, 5u)];
    return PointData(
        target_of(subgroupBroadcast(mine, 0u), subgroupBroadcast(mine, 1u)),
        jet_of(
            subgroupBroadcast(mine, 2u),
            subgroupBroadcast(mine, 3u),
            subgroupBroadcast(mine, 4u),
            subgroupBroadcast(mine, 5u),
        ),
    );
}
