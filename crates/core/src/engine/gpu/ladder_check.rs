//! The WGSL ladder rules of the generated header ([`crate::engine::ladder::WGSL`]) against
//! the Rust ones ([`Rung::judge`], [`Rung::advance`], [`Tolerance::ratio`]), case by case on
//! a table run through a small kernel on the adapter (lavapipe in CI).

use super::AdapterChoice;
use super::kernels::shader_header;
use super::{GpuContext, REQUIRE_GPU_ENV, read_buffer};
use crate::engine::ladder::{GROW, MAX_LEVEL, Rung, Tolerance, UNIT};
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
/// and not to the coarser step, errors on both sides of 1 and of GROW. GROW itself is left
/// out: the kernel compares in f32, where 0.1 rounds up, so an error of exactly 0.1f32 grows
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
                assert!((f64::from(e) - GROW).abs() > 1e-6);
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

fn run_table(ctx: &GpuContext, cases: &[Case]) -> Vec<Out> {
    let source = shader_header(3) + KERNEL;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("ladder table"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("ladder table"),
        layout: None,
        module: &module,
        entry_point: Some("ladder_table"),
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
    let out_bytes = (cases.len() * std::mem::size_of::<Out>()) as u64;
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

#[test]
fn the_kernels_ladder_rules_are_the_rust_ones_case_by_case() {
    let ctx = match GpuContext::new(AdapterChoice::Any) {
        Ok(c) => c,
        Err(e) if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") => {
            panic!("{REQUIRE_GPU_ENV}=1 but no GPU adapter: {e}")
        }
        Err(e) => return eprintln!("SKIPPED: no GPU adapter ({e})"),
    };
    let table = cases();
    let inputs: Vec<Case> = table.iter().map(|c| c.0).collect();
    let outs = run_table(&ctx, &inputs);
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
