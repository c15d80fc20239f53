//! The shared rules (written once, [`crate::rules`]) as the kernels run them, in `f32` on the
//! adapter (lavapipe in CI), against the CPU engine's calls in `f64`, case by case on tables
//! run through small kernels: the ladder's ([`Rung::judge`], [`Rung::advance`],
//! [`Tolerance::ratio`]), the hop count's, the verdict's and the early stop's, and λ1's block,
//! the early stop's continuation and the health check's. Beside them,
//! the kernels' compensated sum, which a shader compiler may fold to nothing.

use super::AdapterChoice;
use super::kernels::shader_header;
use super::{GpuContext, REQUIRE_GPU_ENV, read_buffer};
use crate::analysis::periodicity::{is_hop, next_well, well_side};
use crate::engine::early_rule::{
    cycle_copy, early_close, early_lyapunov_stops_at, early_twin_window,
};
use crate::engine::ladder::{LADDER_GROW, MAX_LEVEL, Rung, Tolerance, UNIT};
use crate::model::guard_status;
use crate::reduce::lyapunov::{LYAPUNOV_MAX_WINDOW, lyapunov_block};
use crate::reduce::regime::{K_FIRM_SAMPLES, lambda_class, regime_code};
use bytemuck::{Pod, Zeroable};

/// One case: a try of error `e` at level `k` from position `pos`, and a norm component.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Case {
    e: f32,
    k: u32,
    /// The position after the sub-step, as the kernel passes it.
    pos_after: u32,
    x: f32,
    y: f32,
    rtol: f32,
    atol: f32,
    pad: u32,
}

/// What the kernel made of a case.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
struct Out {
    rejects: u32,
    next: u32,
    ratio: f32,
    pad: u32,
}

const KERNEL: &str = "
struct Case { e: f32, k: u32, pos_after: u32, x: f32, y: f32, rtol: f32, atol: f32, pad: u32 }
struct Out { rejects: u32, next: u32, ratio: f32, pad: u32 }
@group(0) @binding(0) var<storage, read> cases: array<Case>;
@group(0) @binding(1) var<storage, read_write> outs: array<Out>;
@compute @workgroup_size(64)
fn ladder_table(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    let rejects = select(0u, 1u, ladder_rejects(c.e, c.k));
    outs[i] = Out(rejects, ladder_next_level(c.k, c.pos_after, c.e), ladder_ratio(c.x, c.y, c.rtol, c.atol), 0u);
}
";

/// The table: every level class (coarsest, mid, next to finest, finest), positions aligned
/// and not to the coarser step, errors on both sides of 1 and of LADDER_GROW. LADDER_GROW
/// itself is left out: the kernel compares in f32, where 0.1 rounds up, so an error of exactly 0.1f32 grows
/// there and not in f64; an error that close to the threshold is a tie either may break.
fn cases() -> Vec<(Case, Rung, f64)> {
    let errors = [
        0.0f32,
        0.01,
        0.0999,
        0.1001,
        0.5,
        1.0,
        1.0001,
        7.0,
        f32::INFINITY,
    ];
    let mut out = Vec::new();
    for k in [0, 1, 2, 7, MAX_LEVEL - 1, MAX_LEVEL] {
        let span = UNIT >> k;
        let starts = [0, span, 2 * span, 3 * span].map(|p| p % UNIT);
        for pos in starts {
            for (i, &e) in errors.iter().enumerate() {
                assert!((f64::from(e) - LADDER_GROW).abs() > 1e-6);
                let case = Case {
                    e,
                    k,
                    pos_after: (pos + span) as u32,
                    x: [1e-7, -3e-4, 0.2][i % 3],
                    y: [0.0, -1.5, 40.0][(i + k as usize) % 3],
                    rtol: [1e-3, 1e-5][i % 2],
                    atol: [1e-6, 1e-8][(i / 2) % 2],
                    pad: 0,
                };
                out.push((case, Rung { level: k, pos }, f64::from(e)));
            }
        }
    }
    out
}

/// The results of `entry` of `kernel` (behind the kernels' header) on `cases`: one `O` per
/// case, binding 0 the cases, binding 1 the results.
fn run_table<I: Pod, O: Pod>(ctx: &GpuContext, kernel: &str, entry: &str, cases: &[I]) -> Vec<O> {
    let source = shader_header(3) + kernel;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(entry),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    let input = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cases"),
        size: std::mem::size_of_val(cases) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue
        .write_buffer(&input, 0, bytemuck::cast_slice(cases));
    let out_bytes = (cases.len() * std::mem::size_of::<O>()) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("outs"),
        size: out_bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    ctx.submit(enc.finish());
    read_buffer(ctx, &output, out_bytes).expect("the table's results")
}

/// The adapter, or `None` (the test skipped) where there is none and none is required.
fn adapter() -> Option<GpuContext> {
    match GpuContext::new(AdapterChoice::Any) {
        Ok(c) => Some(c),
        Err(e) if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") => {
            panic!("{REQUIRE_GPU_ENV}=1 but no GPU adapter: {e}")
        }
        Err(e) => {
            eprintln!("SKIPPED: no GPU adapter ({e})");
            None
        }
    }
}

#[test]
fn the_kernels_ladder_rules_are_the_rust_ones_case_by_case() {
    let Some(ctx) = adapter() else { return };
    let table = cases();
    let inputs: Vec<Case> = table.iter().map(|c| c.0).collect();
    let outs: Vec<Out> = run_table(&ctx, KERNEL, "ladder_table", &inputs);
    assert_eq!(outs.len(), table.len());
    let (mut grew, mut rejected) = (0, 0);
    for ((case, rung, e), out) in table.iter().zip(&outs) {
        let mut judged = *rung;
        let accepted = judged.judge(*e);
        assert_eq!(out.rejects == 1, !accepted, "{case:?}");
        rejected += usize::from(!accepted);
        if accepted {
            let mut moved = judged;
            moved.advance(*e);
            assert_eq!(out.next, moved.level, "{case:?}");
            grew += usize::from(moved.level < rung.level);
        }
        let tol = Tolerance {
            rtol: f64::from(case.rtol),
            atol: f64::from(case.atol),
        };
        let want = tol.ratio(f64::from(case.x), f64::from(case.y));
        let got = f64::from(out.ratio);
        assert!(
            (got - want).abs() <= 4e-7 * want.abs(),
            "{case:?}: {got} vs {want}"
        );
    }
    // The table reaches every branch: rejections, growth, and accepted steps that stay.
    assert!(rejected > 0 && grew > 0 && grew + rejected < table.len());
}

/// One case of the hop count's, the verdict's and the early stop's rules.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct VerdictCase {
    alpha: f32,
    half: f32,
    last: i32,
    lambda: f32,
    sigma: f32,
    periodic: u32,
    k: f32,
    k_samples: u32,
    a: f32,
    b: f32,
    tol: f32,
    per_s: f32,
    se_per_s: f32,
    period_s: f32,
}

/// What the kernel made of a case.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
struct VerdictOut {
    side: i32,
    hop: u32,
    next: i32,
    growth: u32,
    regime: i32,
    close: u32,
    stops: u32,
    pad: u32,
}

const VERDICT_KERNEL: &str = "
struct VerdictCase { alpha: f32, half: f32, last: i32, lambda: f32, sigma: f32, periodic: u32,
    k: f32, k_samples: u32, a: f32, b: f32, tol: f32, per_s: f32, se_per_s: f32, period_s: f32 }
struct VerdictOut { side: i32, hop: u32, next: i32, growth: u32, regime: i32, close: u32,
    stops: u32, pad: u32 }
@group(0) @binding(0) var<storage, read> cases: array<VerdictCase>;
@group(0) @binding(1) var<storage, read_write> outs: array<VerdictOut>;
@compute @workgroup_size(64)
fn verdict_table(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    let side = well_side(c.alpha, c.half);
    outs[i] = VerdictOut(
        side,
        select(0u, 1u, is_hop(c.last, side)),
        next_well(c.last, side),
        lambda_class(c.lambda, c.sigma),
        regime_code(c.lambda, c.sigma, c.periodic != 0u, c.k, c.k_samples),
        select(0u, 1u, early_close(c.a, c.b, c.tol)),
        select(0u, 1u, early_lyapunov_stops_at(c.per_s, c.se_per_s, c.period_s)),
        0u,
    );
}
";

/// Every combination of λ1's class (its values at least 0.002 from a class bound, where f32
/// and f64 agree), a period or none, K high, low or NaN and firm or not; beside them, by the
/// row's index, samples above, below and inside the band and NaN from each last well,
/// close and distant pairs, and λ1 that lets an orbit stop and that does not.
fn verdict_cases() -> Vec<VerdictCase> {
    let nan = f32::NAN;
    let firm = K_FIRM_SAMPLES;
    let alphas = [0.3f32, -0.3, 0.05, -0.05, nan];
    let lasts = [-1i32, 0, 1];
    let pairs = [
        (1.0f32, 1.00001f32, 1e-4f32),
        (1.0, 1.001, 1e-4),
        (50.0, 50.001, 1e-4),
        (0.0, 1e-5, 1e-4),
        (0.0, 1e-3, 1e-4),
        (nan, 1.0, 1e-4),
    ];
    let stops = [
        (-8.0f32, 0.1f32, 0.125f32),
        (-8.0, 1.0, 0.125),
        (-0.01, 0.0, 0.125),
        (4.0, 0.1, 0.125),
        (nan, 0.1, 0.125),
    ];
    let mut out = Vec::new();
    for lambda in [-0.5f32, -0.02, 0.0, 0.005, 0.05, 0.4, nan, f32::INFINITY] {
        for sigma in [0.0f32, 0.001, 0.3, nan] {
            for periodic in [0u32, 1] {
                for k in [0.1f32, 0.9, nan] {
                    for k_samples in [firm - 1, firm] {
                        let i = out.len();
                        let (a, b, tol) = pairs[i % pairs.len()];
                        let (per_s, se_per_s, period_s) = stops[i % stops.len()];
                        out.push(VerdictCase {
                            alpha: alphas[i % alphas.len()],
                            half: 0.1,
                            last: lasts[(i / alphas.len()) % lasts.len()],
                            lambda,
                            sigma,
                            periodic,
                            k,
                            k_samples,
                            a,
                            b,
                            tol,
                            per_s,
                            se_per_s,
                            period_s,
                        });
                    }
                }
            }
        }
    }
    out
}

/// The hop count's, the verdict's and the early stop's shared rules give in the kernels, in
/// f32, what they give the CPU engine in f64, case by case.
#[test]
fn the_kernels_hop_verdict_and_early_stop_rules_are_the_rust_ones_case_by_case() {
    let Some(ctx) = adapter() else { return };
    let cases = verdict_cases();
    let outs: Vec<VerdictOut> = run_table(&ctx, VERDICT_KERNEL, "verdict_table", &cases);
    assert_eq!(outs.len(), cases.len());
    let w = f64::from;
    let mut regimes = std::collections::BTreeSet::new();
    for (c, out) in cases.iter().zip(&outs) {
        let side = well_side(w(c.alpha), w(c.half));
        let want = VerdictOut {
            side,
            hop: u32::from(is_hop(c.last, side)),
            next: next_well(c.last, side),
            growth: lambda_class(w(c.lambda), w(c.sigma)),
            regime: regime_code(
                w(c.lambda),
                w(c.sigma),
                c.periodic != 0,
                w(c.k),
                c.k_samples,
            ),
            close: u32::from(early_close(w(c.a), w(c.b), w(c.tol))),
            stops: u32::from(early_lyapunov_stops_at(
                w(c.per_s),
                w(c.se_per_s),
                w(c.period_s),
            )),
            pad: 0,
        };
        assert_eq!(*out, want, "{c:?}");
        regimes.insert(want.regime);
    }
    // Every regime a run that ended ok can have is reached, and every other outcome.
    assert_eq!(regimes.len(), 4, "{regimes:?}");
    for field in [
        |o: &VerdictOut| o.hop as i32,
        |o: &VerdictOut| o.close as i32,
        |o: &VerdictOut| o.stops as i32,
        |o: &VerdictOut| o.side,
        |o: &VerdictOut| o.growth as i32,
    ] {
        let seen: std::collections::BTreeSet<i32> = outs.iter().map(field).collect();
        assert!(seen.len() >= 2, "{seen:?}");
    }
}

/// One case of the bookkeeping rules: λ1's block, the early stop's twin window and its
/// continuation's source instant, and the health check's status.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct BookCase {
    k: u32,
    window: u32,
    p: u32,
    s: u32,
    last: u32,
    cycle: u32,
    finite: u32,
    holder: f32,
    bend: f32,
    energy: f32,
    max_holder: f32,
    max_bend: f32,
    max_energy: f32,
}

/// What the kernel made of a case.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
struct BookOut {
    block: u32,
    window: u32,
    copy: u32,
    status: u32,
}

const BOOK_KERNEL: &str = "
struct BookCase { k: u32, window: u32, p: u32, s: u32, last: u32, cycle: u32, finite: u32,
    holder: f32, bend: f32, energy: f32, max_holder: f32, max_bend: f32, max_energy: f32 }
struct BookOut { block: u32, window: u32, copy: u32, status: u32 }
@group(0) @binding(0) var<storage, read> cases: array<BookCase>;
@group(0) @binding(1) var<storage, read_write> outs: array<BookOut>;
@compute @workgroup_size(64)
fn book_table(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    outs[i] = BookOut(
        lyapunov_block(c.k, c.window),
        early_twin_window(c.p),
        cycle_copy(c.s, c.last, c.cycle),
        guard_status(c.finite != 0u, c.holder, c.bend, c.energy, c.max_holder, c.max_bend,
            c.max_energy),
    );
}
";

/// Growths before, at and past a block's edge and the window's, windows from the shortest to
/// the longest a plan allows; every order of the guard's checks, bounds crossed and not, an
/// energy NaN, infinite, negative; beside them, by the row's index, periods and instants
/// before, at and after the cycle's end, up to `u32::MAX`.
fn book_cases() -> Vec<BookCase> {
    let max_w = LYAPUNOV_MAX_WINDOW;
    let copies = [
        (5u32, 9u32, 2u32),
        (10, 9, 2),
        (11, 9, 2),
        (17, 9, 4),
        (1000, 640, 64),
        (u32::MAX, u32::MAX - 10, 100),
        (u32::MAX - 3, 12, 7),
    ];
    let mut out = Vec::new();
    for (k, window) in [
        (0u32, 16u32),
        (1, 16),
        (5, 16),
        (9, 17),
        (2, 17),
        (15, 16),
        (16, 16),
        (40, 16),
        (999, 1000),
        (max_w / 2, max_w),
        (max_w - 1, max_w),
        (3, 1),
        (5, 0),
    ] {
        for finite in [0u32, 1] {
            for holder in [0.2f32, 1.5707964, 1.6] {
                for bend in [0.0f32, 1.4, 1.5, 1.51] {
                    for energy in [0.5f32, -99.0, 101.0, f32::NAN, f32::INFINITY] {
                        let i = out.len();
                        let (s, last, cycle) = copies[i % copies.len()];
                        out.push(BookCase {
                            k,
                            window,
                            p: [0u32, 1, 2, 3, 8][i % 5],
                            s,
                            last,
                            cycle,
                            finite,
                            holder,
                            bend,
                            energy,
                            max_holder: 1.5707964,
                            max_bend: 1.5,
                            max_energy: 100.0,
                        });
                    }
                }
            }
        }
    }
    out
}

/// The bookkeeping rules the kernels share with the CPU engine (λ1's block, the early stop's
/// twin window and continuation, the health check's order) give on the adapter what they give
/// in Rust, case by case.
#[test]
fn the_kernels_bookkeeping_and_health_rules_are_the_rust_ones_case_by_case() {
    let Some(ctx) = adapter() else { return };
    let cases = book_cases();
    let outs: Vec<BookOut> = run_table(&ctx, BOOK_KERNEL, "book_table", &cases);
    assert_eq!(outs.len(), cases.len());
    let w = f64::from;
    let mut statuses = std::collections::BTreeSet::new();
    for (c, out) in cases.iter().zip(&outs) {
        let want = BookOut {
            block: lyapunov_block(c.k, c.window),
            window: early_twin_window(c.p),
            copy: cycle_copy(c.s, c.last, c.cycle),
            status: guard_status(
                c.finite != 0,
                w(c.holder),
                w(c.bend),
                w(c.energy),
                w(c.max_holder),
                w(c.max_bend),
                w(c.max_energy),
            ),
        };
        assert_eq!(*out, want, "{c:?}");
        statuses.insert(want.status);
    }
    assert_eq!(statuses.len(), 4, "{statuses:?}");
    let blocks: std::collections::BTreeSet<u32> = outs.iter().map(|o| o.block).collect();
    assert!(
        blocks.contains(&0) && blocks.contains(&7) && blocks.len() >= 4,
        "{blocks:?}"
    );
}

/// A compensated sum `s = y + c`, `(s − y) − c` (the rounding error) as the kernels write it,
/// `s` multiplied by a 1 read at run time ([`crate::model::Lane::opaque`]), and as written
/// plainly: lavapipe folds the plain one to 0.
const COMPENSATED: &str = "
@group(0) @binding(0) var<storage, read> cases: array<vec2<f32>>;
@group(0) @binding(1) var<storage, read_write> outs: array<vec2<f32>>;
@compute @workgroup_size(64)
fn compensated(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let y = cases[i].x;
    let c = cases[i].y;
    let one = cases[0].x;
    let s = y + c;
    outs[i] = vec2<f32>((s * one - y) - c, (s - y) - c);
}
";

/// The kernels' compensated sums keep their compensation on the adapter: the rounding error
/// of `y + c` in f32, bit for bit as the CPU engine's `compensated_add` has it. (Without the
/// run-time 1 lavapipe compiled `(s − y) − c` to 0, so the GPU engine's sums went
/// uncompensated; the plain form's result is printed, not held, as an adapter may keep it.)
#[test]
fn the_kernels_compensated_sums_keep_their_rounding_error() {
    let Some(ctx) = adapter() else { return };
    let cases: Vec<[f32; 2]> = vec![
        [1.0, 1e-8],
        [1.0, 3e-8],
        [0.1, 1e-9],
        [1.0, 0.1],
        [-2.5, 7e-7],
        [40.0, -3e-6],
    ];
    let outs: Vec<[f32; 2]> = run_table(&ctx, COMPENSATED, "compensated", &cases);
    for (&[y, c], &[kept, plain]) in cases.iter().zip(&outs) {
        let (mut sum, mut comp) = (y, 0.0f32);
        crate::engine::stepper::compensated_add(&mut sum, &mut comp, c);
        assert_eq!(
            kept.to_bits(),
            comp.to_bits(),
            "y {y} + {c}: adapter {kept}, CPU {comp}"
        );
        println!("y {y} + {c}: compensation {kept} (written plainly: {plain})");
    }
}
