//! One definition of each struct the GPU reads or writes. `gpu_struct!` declares the Rust
//! struct (`#[repr(C)]`, [`bytemuck::Pod`]) and lists its members with their WGSL types and
//! byte offsets ([`GpuStruct::members`]), so the WGSL struct is written from it
//! ([`GpuStruct::wgsl`], into the kernels' generated header) rather than by hand. One test
//! compares each with the layout naga gives the WGSL text (`tests/suite/engine/layout.rs`).

/// A member type with a WGSL spelling: `f32`, `u32`, `i32` and fixed arrays of them.
pub trait WgslMember {
    /// The WGSL type.
    fn wgsl() -> String;
}

macro_rules! scalar_member {
    ($($t:ty),*) => {$(
        impl WgslMember for $t {
            fn wgsl() -> String {
                stringify!($t).to_string()
            }
        }
    )*};
}

scalar_member!(f32, u32, i32);

impl<T: WgslMember, const N: usize> WgslMember for [T; N] {
    fn wgsl() -> String {
        format!("array<{}, {N}>", T::wgsl())
    }
}

/// A member of a GPU struct.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Member {
    /// Its name, in both languages.
    pub name: &'static str,
    /// Its WGSL type.
    pub wgsl: String,
    /// Its byte offset in the Rust struct (and, the layout test checks, in the WGSL one).
    pub offset: usize,
    /// The first line of its doc comment.
    pub doc: &'static str,
}

/// A struct shared with the kernels, declared by `gpu_struct!`.
pub trait GpuStruct: Sized {
    /// Its WGSL name.
    const WGSL_NAME: &'static str;
    /// Its Rust name.
    const RUST_NAME: &'static str;
    /// Its members, in order.
    fn members() -> Vec<Member>;

    /// The WGSL struct, each member with its doc line.
    fn wgsl() -> String {
        let mut s = format!(
            "// Generated from `{}` (src/engine/gpu/layout.rs).\nstruct {} {{\n",
            Self::RUST_NAME,
            Self::WGSL_NAME
        );
        for m in Self::members() {
            s += &format!("    {}: {}, // {}\n", m.name, m.wgsl, m.doc.trim());
        }
        s + "}\n"
    }
}

/// Declare a struct the GPU reads or writes: `#[repr(C)]`, `Pod`, and its [`GpuStruct`]
/// members (each field documented with `///`, whose first line the WGSL carries).
macro_rules! gpu_struct {
    (
        $(#[doc = $sdoc:expr])*
        pub struct $name:ident as $wgsl:literal {
            $(
                #[doc = $doc:expr]
                $(#[doc = $more:expr])*
                pub $field:ident : $ty:ty
            ),* $(,)?
        }
    ) => {
        $(#[doc = $sdoc])*
        #[repr(C)]
        #[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $(
                #[doc = $doc]
                $(#[doc = $more])*
                pub $field: $ty,
            )*
        }

        impl $crate::engine::gpu::gpu_struct::GpuStruct for $name {
            const WGSL_NAME: &'static str = $wgsl;
            const RUST_NAME: &'static str = stringify!($name);
            fn members() -> Vec<$crate::engine::gpu::gpu_struct::Member> {
                use $crate::engine::gpu::gpu_struct::{Member, WgslMember};
                vec![$(Member {
                    name: stringify!($field),
                    wgsl: <$ty as WgslMember>::wgsl(),
                    offset: std::mem::offset_of!($name, $field),
                    doc: $doc,
                }),*]
            }
        }
    };
}

pub(crate) use gpu_struct;
