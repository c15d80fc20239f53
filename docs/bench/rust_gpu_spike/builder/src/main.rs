//! Compiles `../shader` with rust-gpu to SPIR-V, reads it back with naga's SPIR-V front end,
//! validates it, and writes it out as WGSL (`spike_output.wgsl` in the working directory).
use spirv_builder::{ModuleResult, SpirvBuilder};

/// rust-gpu 0.11's pinned toolchain (`channel` in rustc_codegen_spirv's build.rs).
const TOOLCHAIN: &str = "nightly-2026-08-15";

fn main() {
    let t = std::time::Instant::now();
    let shader = concat!(env!("CARGO_MANIFEST_DIR"), "/../shader");
    let mut builder = SpirvBuilder::new(shader, "spirv-unknown-vulkan1.2").release(true);
    builder.toolchain_overwrite = Some(TOOLCHAIN.into());
    let res = builder.build().expect("shader build");
    println!("shader crate built in {:.1} s", t.elapsed().as_secs_f64());
    let ModuleResult::SingleModule(path) = res.module else {
        panic!("one module expected")
    };
    let bytes = std::fs::read(&path).unwrap();
    println!("SPIR-V: {} ({} bytes)", path.display(), bytes.len());
    let module =
        naga::front::spv::parse_u8_slice(&bytes, &Default::default()).expect("naga spv-in");
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .expect("naga validates");
    let wgsl =
        naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
            .unwrap();
    std::fs::write("spike_output.wgsl", &wgsl).unwrap();
    println!("WGSL: {} lines", wgsl.lines().count());
}
