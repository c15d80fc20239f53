
// ---- the integration's schedule, on the device (src/engine/gpu/mod.rs: integrate) --------
//
// After each dispatch of `integrate`, `compact` keeps the instances of the live half that
// have not finished (`done`) in the other half and counts them in sched[SCHED_LIVE]; `schedule`
// turns the count into the next dispatch's workgroups (sched[0..3]). A workgroup keeps its
// instances in their order (a scan in workgroup memory) and reserves its block with one atomic,
// so the list stays in sorted runs and neighbouring invocations keep touching neighbouring
// words; the blocks' order is the device's (an instance's numbers never depend on which
// invocation runs it). The host copies the count into ctl.n_active at the start of the next
// dispatch's commands and reads it back only to know when every instance has finished: it
// never reads the `done` flags nor uploads a list.

var<workgroup> kept_before: array<u32, WG>; // inclusive scan of the workgroup's keep flags
var<workgroup> block_base: u32;             // where the workgroup's block starts

// Keep the unfinished instances of the live half in the other half.
@compute @workgroup_size(WG)
fn compact(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    var inst = 0u;
    var keep = 0u;
    if gid.x < ctl.n_active {
        inst = live[ctl.live_from + gid.x];
        keep = select(0u, 1u, done[inst] == 0u);
    }
    kept_before[li] = keep;
    workgroupBarrier();
    for (var d = 1u; d < WG; d = d * 2u) {
        var add = 0u;
        if li >= d {
            add = kept_before[li - d];
        }
        workgroupBarrier();
        kept_before[li] += add;
        workgroupBarrier();
    }
    if li == WG - 1u {
        block_base = atomicAdd(&sched[SCHED_LIVE], kept_before[li]);
    }
    workgroupBarrier();
    if keep == 1u {
        let other = select(0u, ctl.n_inst, ctl.live_from == 0u);
        live[other + block_base + kept_before[li] - 1u] = inst;
    }
}

// The next dispatch's workgroup count, from the instances `compact` kept: one per WG instances.
@compute @workgroup_size(1)
fn schedule() {
    let live_n = atomicLoad(&sched[SCHED_LIVE]);
    atomicStore(&sched[0], (live_n + WG - 1u) / WG);
    atomicStore(&sched[1], 1u);
    atomicStore(&sched[2], 1u);
}
