#![no_std]
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// The hop rule's side (the same text as the product's shared rule).
pub fn well_side(alpha: f32, half: f32) -> i32 {
    if alpha > half {
        1
    } else if alpha < -half {
        -1
    } else {
        0
    }
}

/// A loop with a run-time trip count and early exit: what the tracer cannot record.
pub fn first_close(xs: &[f32], p: usize, tol: f32) -> u32 {
    let mut i = p;
    while i < xs.len() {
        if (xs[i] - xs[i - p]).abs() > tol * xs[i].abs().max(1.0) {
            return 0;
        }
        i += 1;
    }
    p as u32
}

#[spirv(compute(threads(64)))]
pub fn main_cs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] a: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] out: &mut [i32],
) {
    let i = id.x as usize;
    if i < out.len() {
        out[i] = well_side(a[i], 0.1) + first_close(a, 2, 1e-4) as i32;
    }
}
