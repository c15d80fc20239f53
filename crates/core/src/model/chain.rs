//! The equations of motion M(θ)θ̈ = Q (`docs/model.md`), solved in O(N) per evaluation.
//!
//! The serial chain is solved articulated-body style (a Newton–Euler recursion): a backward
//! sweep from the tip condenses the chain above node i−1 into a 2×2 articulated inertia `K_i`
//! and a bias force `p_i` (force needed at node i−1 = K_i·a_{i−1} + p_i); a forward sweep from
//! the cart's known acceleration then yields θ̈_i segment by segment. Springs, dampers, the
//! bumper contact and the piezo enter as generalised forces Q_i (couples on segment i), which
//! is exactly how they appear in the Lagrange equations. [`crate::model::dense`] builds the
//! dense M and Q term by term for the cross-check in tests.

use crate::model::lane::{Lane, Real};
use crate::model::params::{ContactDamping, ContactParams, ModelParams, PiezoParams};

/// Which branch of the force law a bumper is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BumperMode {
    /// Not pushing: F = 0.
    Free,
    /// Spring only: F = k_c δ (the loading law while the penetration shrinks).
    Spring,
    /// Spring and damper: F = k_c δ + c_c δ̇.
    SpringDamper,
}

/// How the bumper force law is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactLaw {
    /// The physical law of the scene (`limiter.damping_law`): loading-only damping,
    /// F = k_c δ + c_c max(δ̇, 0), or Kelvin–Voigt, F = max(0, k_c δ + c_c δ̇), while δ > 0.
    Exact,
    /// Each bumper frozen on one branch of the law (any sign, no clipping): the smooth pieces
    /// between contact events, used by the event-locating reference integrator.
    Frozen {
        /// The +x bumper's branch.
        right: BumperMode,
        /// The −x bumper's branch.
        left: BumperMode,
    },
}

/// The branch of the exact law a bumper with penetration `delta` (m) and penetration rate
/// `rate` (m/s) is on.
#[inline]
pub fn bumper_mode<T: Real>(law: ContactDamping, kc: T, cc: T, delta: T, rate: T) -> BumperMode {
    let z = T::zero();
    if delta <= z {
        return BumperMode::Free;
    }
    match law {
        ContactDamping::Loading if rate > z => BumperMode::SpringDamper,
        ContactDamping::Loading => BumperMode::Spring,
        ContactDamping::KelvinVoigt if kc * delta + cc * rate > z => BumperMode::SpringDamper,
        ContactDamping::KelvinVoigt => BumperMode::Free,
    }
}

/// The force (N) of a bumper on `mode`'s branch.
#[inline]
pub fn bumper_force<T: Lane>(mode: BumperMode, kc: T, cc: T, delta: T, rate: T) -> T {
    match mode {
        BumperMode::Free => T::splat(0.0),
        BumperMode::Spring => kc * delta,
        BumperMode::SpringDamper => kc * delta + cc * rate,
    }
}

/// The force (N) of a bumper by the exact law, without branches (one value per lane): with
/// penetration δ > 0, loading-only damping F = k_c δ + c_c max(δ̇, 0), Kelvin–Voigt
/// F = max(0, k_c δ + c_c δ̇); F = 0 for δ ≤ 0. Equal to [`bumper_force`] on the branch
/// [`bumper_mode`] picks (adding c_c · 0 and taking max(·, 0) are exact).
#[inline]
pub fn exact_bumper_force<T: Lane>(law: ContactDamping, kc: T, cc: T, delta: T, rate: T) -> T {
    let zero = T::splat(0.0);
    let pushing = match law {
        ContactDamping::Loading => kc * delta + cc * rate.v_max(zero),
        ContactDamping::KelvinVoigt => (kc * delta + cc * rate).v_max(zero),
    };
    T::if_positive(delta, pushing, zero)
}

/// The bumpers at one state: penetrations and the horizontal force on the beam.
#[derive(Debug, Clone, Copy)]
pub struct BumperLoad<T> {
    /// Horizontal force of the bumpers on the beam (N): negative when the +x bumper pushes.
    pub force_x_n: T,
    /// Penetration δ of the +x bumper (m; negative when apart).
    pub right_m: T,
    /// Penetration δ of the −x bumper (m; negative when apart).
    pub left_m: T,
    /// The branches of the exact law the two bumpers are on at this state.
    pub branches: Branches<T>,
}

/// The branch of each bumper's force law, lane by lane, as 0/1 values: whether it pushes
/// (`on`) and whether its damper takes part (`damped`). On a branch the force is
/// `on · (k_c δ + damped · c_c δ̇)` for any δ, δ̇: the smooth piece of the law, which the twin
/// of λ1 follows along its main trajectory (`crate::engine::twin`).
#[derive(Debug, Clone, Copy)]
pub struct Branches<T> {
    /// The +x bumper: (on, damped).
    pub right: (T, T),
    /// The −x bumper: (on, damped).
    pub left: (T, T),
}

impl<T: Lane> Branches<T> {
    /// Both bumpers free.
    pub fn free() -> Self {
        let z = T::splat(0.0);
        Branches {
            right: (z, z),
            left: (z, z),
        }
    }
}

/// The branch of the exact law of a bumper with penetration `delta` and rate `rate`, lane by
/// lane: loading-only damping pushes while δ > 0 and damps while also δ̇ > 0; Kelvin–Voigt
/// pushes (damped) while δ > 0 and k_c δ + c_c δ̇ > 0.
#[inline]
fn branch_of<T: Lane>(law: ContactDamping, kc: T, cc: T, delta: T, rate: T) -> (T, T) {
    let (one, zero) = (T::splat(1.0), T::splat(0.0));
    match law {
        ContactDamping::Loading => {
            let on = T::if_positive(delta, one, zero);
            (
                on,
                T::if_positive(delta, T::if_positive(rate, one, zero), zero),
            )
        }
        ContactDamping::KelvinVoigt => {
            let pushing = T::if_positive(kc * delta + cc * rate, one, zero);
            let on = T::if_positive(delta, pushing, zero);
            (on, on)
        }
    }
}

/// How [`Chain::generalised_forces`] evaluates the bumpers.
#[derive(Debug, Clone, Copy)]
enum BumperLaw<T> {
    /// The law itself, or each bumper frozen on a branch ([`ContactLaw`]).
    Law(ContactLaw),
    /// Each bumper on the given branch, lane by lane.
    On(Branches<T>),
}

/// The chain's coefficients in the engine's number type: one instance (`f64`, `f32`) or one
/// per lane of a vector ([`Lane`]; every lane with the same structure).
#[derive(Debug, Clone)]
pub struct Chain<T: Lane> {
    n: usize,
    l: T,
    m: T,
    j: T,
    tip: T,
    jh: T,
    g: T,
    k: T,
    k0: T,
    b: T,
    b0: T,
    contact: Option<ChainContact<T>>,
    piezo: Option<ChainPiezo<T>>,
}

#[derive(Debug, Clone)]
struct ChainContact<T> {
    levers: Vec<T>,
    gap: T,
    kc: T,
    cc: T,
    law: ContactDamping,
}

#[derive(Debug, Clone)]
struct ChainPiezo<T> {
    last: usize,
    inv_c: T,
    inv_r: T,
    theta: T,
}

/// Per-instance scratch for the recursion (avoids allocation on the hot path).
#[derive(Debug, Clone)]
pub struct Workspace<T> {
    sin: Vec<T>,
    cos: Vec<T>,
    q: Vec<T>,
    h: Vec<[T; 2]>,
    d: Vec<T>,
    beta: Vec<T>,
}

/// Contact state at one instant, as the trajectory reports it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactReport<T> {
    /// Horizontal force of the bumpers on the beam (N): negative when the +x bumper pushes.
    pub force_x_n: T,
    /// The +x bumper is penetrated (δ > 0).
    pub right_touch: bool,
    /// The −x bumper is penetrated (δ > 0).
    pub left_touch: bool,
}

/// Parts of the stored energy (J), inertial frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energy {
    /// Kinetic energy of segments, tip and holder.
    pub kinetic_j: f64,
    /// Gravitational potential (pivot height = 0).
    pub gravity_j: f64,
    /// Joint and root springs.
    pub springs_j: f64,
    /// Elastic energy ½k_cδ² of a penetrated bumper.
    pub contact_j: f64,
    /// ½C_p v² in the piezo capacitance.
    pub electric_j: f64,
}

impl Energy {
    /// Everything stored: mechanical plus electrical.
    pub fn total_j(&self) -> f64 {
        self.kinetic_j + self.gravity_j + self.springs_j + self.contact_j + self.electric_j
    }
}

/// What the chain's equations depend on beyond its coefficients: the segments, how many
/// levers reach the contact point and the bumpers' law, the piezo's span. A [`Chain`] is
/// built for one shape; the GPU's kernels are generated for one (`crate::engine::gpu::codegen`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ChainShape {
    /// Segments N.
    pub segments: usize,
    /// The bumpers: levers reaching the contact point, and the damping law.
    pub contact: Option<(usize, ContactDamping)>,
    /// The piezo: the last segment its patch spans.
    pub piezo_last: Option<usize>,
}

impl ChainShape {
    /// The shape of a built pendulum.
    pub fn of(p: &ModelParams) -> ChainShape {
        ChainShape {
            segments: p.segments,
            contact: p.contact.as_ref().map(|c| (c.levers_m.len(), c.law)),
            piezo_last: p.piezo.as_ref().map(|z| z.last_segment),
        }
    }

    /// The same shape with a lever on every segment (zero past the contact segment, which
    /// adds exact zeros): one shape for every contact height, the GPU kernels' shape.
    pub fn every_lever(self) -> ChainShape {
        ChainShape {
            contact: self.contact.map(|(_, law)| (self.segments, law)),
            ..self
        }
    }
}

/// One coefficient of the chain's equations, by name: what [`Chain::from_coefficients`]
/// asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coefficient {
    /// Segment length ℓ (m).
    SegLength,
    /// Segment mass m (kg).
    SegMass,
    /// Segment centroidal inertia J (kg m²).
    SegInertia,
    /// Tip mass M (kg).
    TipMass,
    /// Holder inertia J_h (kg m²).
    HolderInertia,
    /// Gravity g (m/s²).
    Gravity,
    /// Joint spring k (N m/rad).
    JointStiffness,
    /// Root spring k0 (N m/rad).
    RootStiffness,
    /// Joint damper b (N m s/rad).
    JointDamping,
    /// Root damper b0 (N m s/rad).
    RootDamping,
    /// Lever λ_i of segment i at the contact point (m).
    Lever(usize),
    /// Bumper offset g_c (m).
    BumperGap,
    /// Bumper stiffness k_c (N/m).
    BumperStiffness,
    /// Bumper damping c_c (N s/m).
    BumperDamping,
    /// 1/C_p of the piezo (1/F).
    PiezoInvCapacitance,
    /// 1/R_L of the load (1/Ω).
    PiezoInvLoad,
    /// Coupling Θ (N m/V).
    PiezoCoupling,
}

impl Coefficient {
    /// Its value for a built pendulum (a lever past the contact segment is 0; the bumper's and
    /// the piezo's are 0 without them).
    pub fn of(self, p: &ModelParams) -> f64 {
        let bumper = |f: fn(&ContactParams) -> f64| p.contact.as_ref().map_or(0.0, f);
        let piezo = |f: fn(&PiezoParams) -> f64| p.piezo.as_ref().map_or(0.0, f);
        match self {
            Coefficient::SegLength => p.seg_length_m,
            Coefficient::SegMass => p.seg_mass_kg,
            Coefficient::SegInertia => p.seg_inertia_kgm2,
            Coefficient::TipMass => p.tip_mass_kg,
            Coefficient::HolderInertia => p.holder_inertia_kgm2,
            Coefficient::Gravity => p.g_m_s2,
            Coefficient::JointStiffness => p.joint_stiffness_nm,
            Coefficient::RootStiffness => p.root_stiffness_nm,
            Coefficient::JointDamping => p.joint_damping_nms,
            Coefficient::RootDamping => p.root_damping_nms,
            Coefficient::Lever(i) => p
                .contact
                .as_ref()
                .and_then(|c| c.levers_m.get(i).copied())
                .unwrap_or(0.0),
            Coefficient::BumperGap => bumper(|c| c.gap_m),
            Coefficient::BumperStiffness => bumper(|c| c.stiffness_n_per_m),
            Coefficient::BumperDamping => bumper(|c| c.damping_ns_per_m),
            Coefficient::PiezoInvCapacitance => piezo(|z| 1.0 / z.capacitance_f),
            Coefficient::PiezoInvLoad => piezo(|z| 1.0 / z.load_ohm),
            Coefficient::PiezoCoupling => piezo(|z| z.coupling_nm_per_v),
        }
    }
}

impl<T: Lane> Chain<T> {
    /// Convert the parameter struct to this number type (every lane the same instance).
    pub fn new(p: &ModelParams) -> Self {
        Chain::from_lanes(std::slice::from_ref(p))
    }

    /// One instance per lane: lane i holds `ps[i % ps.len()]`. The instances must share the
    /// structure (segments, bumper lever count and law, piezo span): `Chain::same_structure`.
    pub fn from_lanes(ps: &[ModelParams]) -> Self {
        debug_assert!(ps.iter().all(|q| Self::same_structure(&ps[0], q)));
        Chain::from_coefficients(ChainShape::of(&ps[0]), |c| {
            T::gather(|i| c.of(&ps[i % ps.len()]))
        })
    }

    /// A chain of `shape` whose every coefficient is `value(name)`: numbers gathered from
    /// instances ([`Chain::from_lanes`]), or the symbols a generated kernel reads them from.
    pub fn from_coefficients(shape: ChainShape, mut v: impl FnMut(Coefficient) -> T) -> Self {
        Chain {
            n: shape.segments,
            l: v(Coefficient::SegLength),
            m: v(Coefficient::SegMass),
            j: v(Coefficient::SegInertia),
            tip: v(Coefficient::TipMass),
            jh: v(Coefficient::HolderInertia),
            g: v(Coefficient::Gravity),
            k: v(Coefficient::JointStiffness),
            k0: v(Coefficient::RootStiffness),
            b: v(Coefficient::JointDamping),
            b0: v(Coefficient::RootDamping),
            contact: shape.contact.map(|(levers, law)| ChainContact {
                levers: (0..levers).map(|i| v(Coefficient::Lever(i))).collect(),
                gap: v(Coefficient::BumperGap),
                kc: v(Coefficient::BumperStiffness),
                cc: v(Coefficient::BumperDamping),
                law,
            }),
            piezo: shape.piezo_last.map(|last| ChainPiezo {
                last,
                inv_c: v(Coefficient::PiezoInvCapacitance),
                inv_r: v(Coefficient::PiezoInvLoad),
                theta: v(Coefficient::PiezoCoupling),
            }),
        }
    }

    /// Whether two instances can share a vector: the same segments, bumper levers and law,
    /// and piezo span.
    pub(crate) fn same_structure(a: &ModelParams, b: &ModelParams) -> bool {
        ChainShape::of(a) == ChainShape::of(b)
    }

    /// Number of segments.
    pub fn segments(&self) -> usize {
        self.n
    }

    /// Bumper penetrations (δ_right, δ_left) (m) at state `y` (`None` without bumpers):
    /// a bumper is touched while its δ > 0, which is what counts impacts.
    pub fn penetrations(&self, y: &[T]) -> Option<(T, T)> {
        let c = self.contact.as_ref()?;
        let mut x = T::splat(0.0);
        for (i, &lam) in c.levers.iter().enumerate() {
            x += lam * y[i].v_sin_cos().0;
        }
        Some((x - c.gap, -x - c.gap))
    }

    /// Scratch space sized for this chain.
    pub fn workspace(&self) -> Workspace<T> {
        let z = T::splat(0.0);
        Workspace {
            sin: vec![z; self.n],
            cos: vec![z; self.n],
            q: vec![z; self.n],
            h: vec![[z, z]; self.n],
            d: vec![z; self.n],
            beta: vec![z; self.n],
        }
    }

    /// Bumper penetrations: (δ_right, δ̇_right); the left one is (−x − g_c, −ẋ).
    #[inline]
    fn contact_kinematics(&self, c: &ChainContact<T>, ws: &Workspace<T>, omega: &[T]) -> (T, T) {
        let mut x = T::splat(0.0);
        let mut xd = T::splat(0.0);
        for (i, &lam) in c.levers.iter().enumerate() {
            x += lam * ws.sin[i];
            xd += lam * ws.cos[i] * omega[i];
        }
        (x, xd)
    }

    /// Generalised forces Q_i of springs, dampers, bumpers and the piezo, into `ws.q`.
    /// `sin`/`cos` of the angles must already be in the workspace.
    fn generalised_forces(
        &self,
        ws: &mut Workspace<T>,
        theta: &[T],
        omega: &[T],
        volt: T,
        law: BumperLaw<T>,
    ) -> Option<BumperLoad<T>> {
        let n = self.n;
        ws.q.fill(T::splat(0.0));
        // Root spring/damper (clamped k0, β k0, bearing b0) on the holder.
        ws.q[0] = -self.k0 * theta[0] - self.b0 * omega[0];
        // Joint springs and dampers between segments i−1 and i.
        for i in 1..n {
            let tau = -self.k * (theta[i] - theta[i - 1]) - self.b * (omega[i] - omega[i - 1]);
            ws.q[i] += tau;
            ws.q[i - 1] -= tau;
        }
        let load = self.contact.as_ref().map(|c| {
            let (x, xd) = self.contact_kinematics(c, ws, omega);
            // Penetrations and their rates: (δ, δ̇) of the +x and −x bumpers.
            let (right, left) = ((x - c.gap, xd), (-x - c.gap, -xd));
            let force = |(delta, rate): (T, T), which: usize| match law {
                BumperLaw::Law(ContactLaw::Exact) => {
                    exact_bumper_force(c.law, c.kc, c.cc, delta, rate)
                }
                BumperLaw::Law(ContactLaw::Frozen { right, left }) => {
                    let m = if which == 0 { right } else { left };
                    bumper_force(m, c.kc, c.cc, delta, rate)
                }
                BumperLaw::On(b) => {
                    let (on, damped) = if which == 0 { b.right } else { b.left };
                    on * (c.kc * delta + damped * (c.cc * rate))
                }
            };
            // The bumpers push towards the centre: horizontal force fl − fr on the beam.
            let fx = force(left, 1) - force(right, 0);
            for (i, &lam) in c.levers.iter().enumerate() {
                ws.q[i] += fx * lam * ws.cos[i];
            }
            let branch = |(delta, rate): (T, T)| branch_of(c.law, c.kc, c.cc, delta, rate);
            BumperLoad {
                force_x_n: fx,
                right_m: right.0,
                left_m: left.0,
                branches: Branches {
                    right: branch(right),
                    left: branch(left),
                },
            }
        });
        if let Some(z) = &self.piezo {
            ws.q[0] += z.theta * volt;
            ws.q[z.last] -= z.theta * volt;
        }
        load
    }

    /// Time derivative of the state `y = [θ; θ̇; v]` given the cart acceleration (m/s²), in
    /// every lane; returns the bumpers' load at this state (`None` without bumpers).
    pub fn rates(
        &self,
        ws: &mut Workspace<T>,
        cart_acc: T,
        y: &[T],
        dy: &mut [T],
        law: ContactLaw,
    ) -> Option<BumperLoad<T>> {
        self.rates_by(ws, cart_acc, y, dy, BumperLaw::Law(law))
    }

    /// [`Chain::rates`] with each bumper on the given branch of its law (lane by lane): the
    /// twin of λ1 evaluated on its main trajectory's branches.
    pub(crate) fn rates_on(
        &self,
        ws: &mut Workspace<T>,
        cart_acc: T,
        y: &[T],
        dy: &mut [T],
        branches: Branches<T>,
    ) -> Option<BumperLoad<T>> {
        self.rates_by(ws, cart_acc, y, dy, BumperLaw::On(branches))
    }

    fn rates_by(
        &self,
        ws: &mut Workspace<T>,
        cart_acc: T,
        y: &[T],
        dy: &mut [T],
        law: BumperLaw<T>,
    ) -> Option<BumperLoad<T>> {
        let n = self.n;
        let (theta, rest) = y.split_at(n);
        let (omega, volt) = rest.split_at(n);
        let volt = volt[0];
        for ((th, s), c) in theta.iter().zip(&mut ws.sin).zip(&mut ws.cos) {
            (*s, *c) = th.v_sin_cos();
        }
        let load = self.generalised_forces(ws, theta, omega, volt, law);
        let (dtheta, drest) = dy.split_at_mut(n);
        let (domega, dvolt) = drest.split_at_mut(n);
        dtheta.copy_from_slice(omega);
        self.solve_accelerations(ws, omega, cart_acc, domega);
        dvolt[0] = match &self.piezo {
            Some(z) => (z.theta * (omega[z.last] - omega[0]) - volt * z.inv_r) * z.inv_c,
            None => T::splat(0.0),
        };
        load
    }

    /// The O(N) articulated-body recursion: θ̈ from sin/cos, rates, Q (in `ws`) and ẍ0.
    fn solve_accelerations(&self, ws: &mut Workspace<T>, omega: &[T], cart_acc: T, out: &mut [T]) {
        self.solve_with_gravity(ws, omega, cart_acc, self.g, out);
    }

    /// [`Chain::solve_accelerations`] with gravity `g` (0 for the response to Q alone).
    fn solve_with_gravity(
        &self,
        ws: &mut Workspace<T>,
        omega: &[T],
        cart_acc: T,
        g: T,
        out: &mut [T],
    ) {
        let (l, m) = (self.l, self.m);
        let half = T::splat(0.5);
        let two = T::splat(2.0);
        let hml = half * m * l; // mℓ/2
        let base_d = self.j + m * l * l * T::splat(0.25);
        // Articulated inertia of the tip mass and its bias (−M g⃗ = (0, M g)).
        let zero = T::splat(0.0);
        let (mut kxx, mut kxy, mut kyy) = (self.tip, zero, self.tip);
        let (mut px, mut py) = (zero, self.tip * g);
        for i in (0..self.n).rev() {
            let (s, c) = (ws.sin[i], ws.cos[i]);
            // u = (s, c) along the segment, nvec = (c, −s) = ∂u/∂θ.
            let (nx, ny) = (c, -s);
            let w2 = omega[i] * omega[i];
            let knx = kxx * nx + kxy * ny;
            let kny = kxy * nx + kyy * ny;
            let kux = kxx * s + kxy * c;
            let kuy = kxy * s + kyy * c;
            let hx = hml * nx + l * knx;
            let hy = hml * ny + l * kny;
            let mut d = base_d + l * l * (nx * knx + ny * kny);
            if i == 0 {
                d += self.jh;
            }
            // e: bias of the force at the lower node; bias2: of the sum of both node forces.
            let ex = -(hml * s + l * kux) * w2 + px;
            let ey = -(hml * c + l * kuy) * w2 + py + m * g;
            let b2x = -(hml * s + two * l * kux) * w2 + two * px;
            let b2y = -(hml * c + two * l * kuy) * w2 + two * py + m * g;
            let beta = -half * l * (nx * b2x + ny * b2y) + ws.q[i];
            let inv_d = T::splat(1.0) / d;
            kxx = m + kxx - hx * hx * inv_d;
            kxy -= hx * hy * inv_d;
            kyy = m + kyy - hy * hy * inv_d;
            px = ex + hx * beta * inv_d;
            py = ey + hy * beta * inv_d;
            ws.h[i] = [hx, hy];
            ws.d[i] = d;
            ws.beta[i] = beta;
        }
        let (mut ax, mut ay) = (cart_acc, zero);
        for i in 0..self.n {
            let [hx, hy] = ws.h[i];
            let acc = (ws.beta[i] - hx * ax - hy * ay) / ws.d[i];
            out[i] = acc;
            let (s, c) = (ws.sin[i], ws.cos[i]);
            let w2 = omega[i] * omega[i];
            ax += l * (c * acc - s * w2);
            ay += l * (-s * acc - c * w2);
        }
    }
}

impl<T: Lane> Chain<T> {
    /// The angular accelerations `M(θ)⁻¹ (λ_i cos θ_i)` (1/(s² N)) of a unit horizontal force
    /// at the bumpers' contact point, at the angles of `y`, into `out` (length N); false without
    /// bumpers. The response to an impulse there: what a contact's jump in force does.
    pub(crate) fn lever_response(&self, ws: &mut Workspace<T>, y: &[T], out: &mut [T]) -> bool {
        let Some(c) = &self.contact else {
            return false;
        };
        let n = self.n;
        for ((th, s), co) in y[..n].iter().zip(&mut ws.sin).zip(&mut ws.cos) {
            (*s, *co) = th.v_sin_cos();
        }
        ws.q.fill(T::splat(0.0));
        for (i, &lam) in c.levers.iter().enumerate() {
            ws.q[i] = lam * ws.cos[i];
        }
        let zero = vec![T::splat(0.0); n];
        self.solve_with_gravity(ws, &zero, T::splat(0.0), T::splat(0.0), out);
        true
    }

    /// The stored energy's parts `[kinetic, gravity, springs, contact, electric]` (J, inertial
    /// frame) at the state whose component j is `y(j)`, the cart at velocity `cart_v` (m/s),
    /// computed in the number type `U` with each coefficient converted by `w`: f64 from any
    /// chain on the CPU ([`Chain::energy`]), the kernel's f32 on the GPU (whose health check is
    /// generated from this function, `crate::engine::gpu::codegen`).
    ///
    /// Segment i's centre moves at the node's velocity plus ½ℓθ̇_i n_i and sits ½ℓ cos θ_i above
    /// its node; the tip mass rides on the last node; a penetrated bumper stores ½k_c δ², the
    /// patch ½C_p v².
    pub fn energy_in<U: Lane>(
        &self,
        y: impl Fn(usize) -> U,
        cart_v: U,
        w: impl Fn(T) -> U,
    ) -> [U; 5] {
        let n = self.n;
        let (zero, half) = (U::splat(0.0), U::splat(0.5));
        let (l, m, g) = (w(self.l), w(self.m), w(self.g));
        let (mut vx, mut vy) = (cart_v, zero);
        let mut height = zero;
        let [mut kinetic, mut gravity, mut springs] = [zero; 3];
        for i in 0..n {
            let (th, om) = (y(i), y(n + i));
            let (s, c) = th.v_sin_cos();
            let (gvx, gvy) = (vx + half * l * c * om, vy - half * l * s * om);
            kinetic += half * m * (gvx * gvx + gvy * gvy) + half * w(self.j) * om * om;
            gravity += m * g * (height + half * l * c);
            vx += l * c * om;
            vy -= l * s * om;
            height += l * c;
            if i > 0 {
                let rel = th - y(i - 1);
                springs += half * w(self.k) * rel * rel;
            }
        }
        let (th0, om0) = (y(0), y(n));
        kinetic += half * w(self.tip) * (vx * vx + vy * vy) + half * w(self.jh) * om0 * om0;
        gravity += w(self.tip) * g * height;
        springs += half * w(self.k0) * th0 * th0;
        let contact = self.contact.as_ref().map_or(zero, |c| {
            let mut x = zero;
            for (i, &lam) in c.levers.iter().enumerate() {
                x += w(lam) * y(i).v_sin_cos().0;
            }
            let delta = x.v_max(-x) - w(c.gap);
            U::if_positive(delta, half * w(c.kc) * delta * delta, zero)
        });
        let electric = self.piezo.as_ref().map_or(zero, |z| {
            let v = y(2 * n);
            half * v * v / w(z.inv_c)
        });
        [kinetic, gravity, springs, contact, electric]
    }

    /// The bumpers' damping c_c (N s/m), `None` without bumpers.
    pub(crate) fn contact_damping(&self) -> Option<T> {
        self.contact.as_ref().map(|c| c.cc)
    }
}

impl<T: Real> ContactReport<T> {
    fn of(load: Option<BumperLoad<T>>) -> Self {
        load.map_or_else(ContactReport::default, |b| ContactReport {
            force_x_n: b.force_x_n,
            right_touch: b.right_m > T::zero(),
            left_touch: b.left_m > T::zero(),
        })
    }
}

/// The contact point's sideways position x = Σ λ_i sin θ_i (m), which the bumpers at ±gap
/// meet.
fn contact_x<T: Real>(c: &ChainContact<T>, y: &[T]) -> T {
    let mut x = T::zero();
    for (i, &lam) in c.levers.iter().enumerate() {
        x += lam * y[i].sin();
    }
    x
}

impl<T: Real> Chain<T> {
    /// Time derivative of the state `y = [θ; θ̇; v]` of one instance given the cart
    /// acceleration (m/s²), with the contact report at this state ([`Chain::rates`]).
    pub fn derivative(
        &self,
        ws: &mut Workspace<T>,
        cart_acc: T,
        y: &[T],
        dy: &mut [T],
        law: ContactLaw,
    ) -> ContactReport<T> {
        ContactReport::of(self.rates(ws, cart_acc, y, dy, law))
    }

    /// The bumper report (force and touch flags) at a state, with the exact law.
    pub fn contact_report(&self, ws: &mut Workspace<T>, y: &[T]) -> ContactReport<T> {
        let n = self.n;
        for ((th, s), c) in y[..n].iter().zip(&mut ws.sin).zip(&mut ws.cos) {
            (*s, *c) = th.sin_cos();
        }
        let law = BumperLaw::Law(ContactLaw::Exact);
        let load = self.generalised_forces(ws, &y[..n], &y[n..2 * n], y[2 * n], law);
        ContactReport::of(load)
    }

    /// Which bumpers are penetrated (δ > 0): the contact flags used to count impacts.
    pub fn touching(&self, y: &[T]) -> (bool, bool) {
        let Some(c) = &self.contact else {
            return (false, false);
        };
        let x = contact_x(c, y);
        (x - c.gap > T::zero(), -x - c.gap > T::zero())
    }

    /// How far the chain's contact point is from the nearer bumper at this state (m):
    /// `min(gap − x, gap + x)`, negative while a bumper is penetrated; `None` without bumpers.
    /// An orbit whose least margin crosses zero between two scenes grazes a bumper there.
    pub fn bumper_margin(&self, y: &[T]) -> Option<T> {
        let c = self.contact.as_ref()?;
        let x = contact_x(c, y);
        Some((c.gap - x).min(c.gap + x))
    }

    /// Each bumper's switching values at this state, for the +x and the −x bumper:
    /// `[δ, δ̇, k_c δ + c_c δ̇]`, where the law changes branch as one of them changes sign
    /// (`crate::reduce::orbits` locates those instants); `None` without bumpers.
    pub(crate) fn bumper_switches(&self, ws: &mut Workspace<T>, y: &[T]) -> Option<[[T; 3]; 2]> {
        let c = self.contact.as_ref()?;
        let n = self.n;
        let k = c.levers.len();
        for ((th, s), co) in y[..k].iter().zip(&mut ws.sin).zip(&mut ws.cos) {
            (*s, *co) = th.sin_cos();
        }
        let (x, xd) = self.contact_kinematics(c, ws, &y[n..2 * n]);
        let values = |d: T, r: T| [d, r, c.kc * d + c.cc * r];
        Some([values(x - c.gap, xd), values(-x - c.gap, -xd)])
    }

    /// The bumpers' damping law, when the chain has bumpers.
    pub(crate) fn damping_law(&self) -> Option<ContactDamping> {
        self.contact.as_ref().map(|c| c.law)
    }

    /// The branch of the exact law each bumper (+x, −x) is on at this state.
    pub(crate) fn bumper_modes(&self, ws: &mut Workspace<T>, y: &[T]) -> (BumperMode, BumperMode) {
        let (Some(c), Some(v)) = (&self.contact, self.bumper_switches(ws, y)) else {
            return (BumperMode::Free, BumperMode::Free);
        };
        let mode = |[delta, rate, _]: [T; 3]| bumper_mode(c.law, c.kc, c.cc, delta, rate);
        (mode(v[0]), mode(v[1]))
    }

    /// Stored energy in the inertial frame, given the cart velocity (m/s); it does not depend
    /// on the cart position. Computed in f64 from the widened coefficients and state
    /// ([`Chain::energy_in`]).
    pub fn energy(&self, y: &[T], cart_v: f64) -> Energy {
        let e = self.energy_in(|i| y[i].wide(), cart_v, |x| x.wide());
        Energy {
            kinetic_j: e[0],
            gravity_j: e[1],
            springs_j: e[2],
            contact_j: e[3],
            electric_j: e[4],
        }
    }
    /// Power dissipated by the joint, root and contact dampers and the load resistor (W).
    pub fn dissipated_power_w(&self, y: &[T]) -> f64 {
        let n = self.n;
        let w = |x: T| x.wide();
        let mut p = w(self.b0) * w(y[n]).powi(2);
        for i in 1..n {
            p += w(self.b) * (w(y[n + i]) - w(y[n + i - 1])).powi(2);
        }
        if let Some(z) = &self.piezo {
            p += w(y[2 * n]).powi(2) * w(z.inv_r);
        }
        p + self.contact_dissipation_w(y)
    }

    /// Power the bumpers take out of the chain (W): (F − k_c δ) δ̇ of each penetrated bumper,
    /// what its force does beyond storing ½ k_c δ² (c_c max(δ̇, 0)² on the loading law).
    fn contact_dissipation_w(&self, y: &[T]) -> f64 {
        let Some(c) = &self.contact else {
            return 0.0;
        };
        let n = self.n;
        let (mut x, mut xd) = (0.0, 0.0);
        for (i, &lam) in c.levers.iter().enumerate() {
            let (s, co) = y[i].wide().sin_cos();
            x += lam.wide() * s;
            xd += lam.wide() * co * y[n + i].wide();
        }
        let (kc, cc, gap) = (c.kc.wide(), c.cc.wide(), c.gap.wide());
        [(x - gap, xd), (-x - gap, -xd)]
            .iter()
            .map(|&(delta, rate)| {
                let mode = bumper_mode(c.law, kc, cc, delta, rate);
                let f = bumper_force(mode, kc, cc, delta, rate);
                if delta > 0.0 {
                    (f - kc * delta) * rate
                } else {
                    0.0
                }
            })
            .sum()
    }

    /// Tip position relative to the pivot (m) and chord reduction L − |r_N − r_0| (m).
    pub fn tip_and_chord(&self, y: &[T]) -> ((f64, f64), f64) {
        let l = self.l.wide();
        let (mut x, mut z) = (0.0, 0.0);
        for th in &y[..self.n] {
            let (s, c) = th.wide().sin_cos();
            x += l * s;
            z += l * c;
        }
        ((x, z), l * self.n as f64 - (x * x + z * z).sqrt())
    }
}
