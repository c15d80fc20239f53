//! The validation integrator: adaptive DOP853 (Hairer's 8(5,3) pair, from the maintained
//! `ode_solvers` crate) in `f64`, with bumper contact onset and release located as events.
//!
//! Between events the contact law is frozen ([`ContactLaw::Frozen`]), so each piece is a smooth
//! ODE and DOP853 keeps its full order. After every accepted step the exact law's engagement
//! is evaluated; when it differs from the frozen one, the switching time is bisected (to
//! ~1e-13 s) on the frozen piece's continuation, the state is taken just after the switch, and
//! integration restarts with the new law. Output rows fall on the same times as the RK4 plan.
//!
//! Time is integrated as an extra state component (ṫ = 1) and the cart is evaluated at that
//! component, not at the stage time the solver passes: `ode_solvers` 0.6.2 tabulates the
//! DOP853 nodes c12 = c13 = 0 instead of 1, which silently degrades a non-autonomous system to
//! about second order (found by this module's convergence test). The autonomous form is
//! immune, since the weights a_ij alone then determine every stage.

use crate::engine::error::EngineError;
use crate::engine::single::{Instance, Observer, Outcome, POLL_STEPS};
use crate::engine::step_plan::StepPlan;
use crate::model::{BumperMode, CartMotion, Chain, ContactLaw, Status, Workspace};
use nalgebra::DVector;
use ode_solvers::{Dop853, OutputType, System};
use std::cell::RefCell;

/// Tolerances of the reference integrator.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceOptions {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
    /// Largest step (s), if any (see [`ReferenceOptions::for_stiffness`]).
    pub h_max_s: Option<f64>,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions {
            rtol: 1e-11,
            atol: 1e-13,
            h_max_s: None,
        }
    }
}

/// The step cap of a stiff chain in units of 1/max|λ|: just inside DOP853's stability
/// boundary on the negative real axis. With the library damping at N = 17 (max|λ| = 1.0e7 s⁻¹)
/// 0.2 s took 6.5 s with the cap against 7.1 s without (5.5/ρ: 6.9 s, 7/ρ: 7.0 s), both within
/// 1.6e-12 rad of each other.
pub(crate) const STIFF_STEP_CAP: f64 = 6.0;

impl ReferenceOptions {
    /// The default tolerances with the step capped at `STIFF_STEP_CAP``/max|λ|` for a chain
    /// whose linearisation has spectral radius `spectral_radius_per_s`: stiffness answered by a
    /// step below the stability limit, instead of the error controller finding that limit by
    /// trial and rejection. The cap changes the steps, not the tolerances: the result stays the
    /// reference to rtol 1e-11.
    pub fn for_stiffness(spectral_radius_per_s: f64) -> ReferenceOptions {
        ReferenceOptions {
            h_max_s: Some(STIFF_STEP_CAP / spectral_radius_per_s.max(1e-300)),
            ..ReferenceOptions::default()
        }
    }
}

/// One smooth piece: the chain with a frozen contact law, watching for a change of engagement.
struct Piece<'a> {
    chain: &'a Chain<f64>,
    cart: &'a CartMotion,
    ws: RefCell<Workspace<f64>>,
    mode: (BumperMode, BumperMode),
    watch: bool,
    /// Last accepted (t, y) before the engagement changed, and the first one after.
    last_ok: (f64, DVector<f64>),
    switched: Option<(f64, DVector<f64>)>,
}

impl System<f64, DVector<f64>> for &mut Piece<'_> {
    fn system(&self, _t: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
        // Time is carried as the last state component (ṫ = 1), see the module docs.
        let dim = y.len() - 1;
        let a = self.cart.at_time(y[dim]).a_m_s2;
        let law = ContactLaw::Frozen {
            right: self.mode.0,
            left: self.mode.1,
        };
        self.chain.derivative(
            &mut self.ws.borrow_mut(),
            a,
            &y.as_slice()[..dim],
            &mut dy.as_mut_slice()[..dim],
            law,
        );
        dy[dim] = 1.0;
    }

    fn solout(&mut self, t: f64, y: &DVector<f64>, _dy: &DVector<f64>) -> bool {
        if !self.watch {
            return false;
        }
        let now = self
            .chain
            .bumper_modes(&mut self.ws.borrow_mut(), &y.as_slice()[..y.len() - 1]);
        if now != self.mode {
            self.switched = Some((t, y.clone()));
            return true;
        }
        self.last_ok = (t, y.clone());
        false
    }
}

/// Integrate `piece` from (t0, y0) to t1 with its frozen law. Returns the final (t, y).
fn run_piece(
    piece: &mut Piece<'_>,
    t0: f64,
    y0: &DVector<f64>,
    t1: f64,
    opts: &ReferenceOptions,
) -> Result<(f64, DVector<f64>), EngineError> {
    piece.last_ok = (t0, y0.clone());
    piece.switched = None;
    let mut solver = Dop853::from_param(
        &mut *piece,
        t0,
        t1,
        t1 - t0,
        y0.clone(),
        opts.rtol,
        opts.atol,
        0.9,
        0.0,
        0.333,
        6.0,
        opts.h_max_s.map_or(t1 - t0, |h| h.min(t1 - t0)),
        0.0,
        u32::MAX,
        u32::MAX,
        OutputType::Sparse,
    );
    solver
        .integrate()
        .map_err(|e| EngineError::Reference(format!("at t = {t0:e} s: {e}")))?;
    let t = *solver.x_out().last().expect("at least the initial point");
    let y = solver
        .y_out()
        .last()
        .expect("at least the initial point")
        .clone();
    Ok((t, y))
}

/// Integrate one instance with the event-locating DOP853, observing the same rows as RK4. A
/// piece ends at the next row, at a contact switch, or after [`POLL_STEPS`] steps' time,
/// where the observer is polled (a cancel between sparse rows).
pub fn integrate_reference<O: Observer<f64>>(
    inst: &Instance<f64>,
    plan: &StepPlan,
    opts: &ReferenceOptions,
    obs: &mut O,
) -> Result<Outcome, EngineError> {
    let chain = &inst.chain;
    let mut ws = chain.workspace();
    let dim = inst.y0.len();
    let mut y = DVector::from_fn(dim + 1, |i, _| if i < dim { inst.y0[i] } else { 0.0 });
    let mut piece = Piece {
        chain,
        cart: &inst.cart,
        ws: RefCell::new(chain.workspace()),
        mode: chain.bumper_modes(&mut ws, &y.as_slice()[..dim]),
        watch: true,
        last_ok: (0.0, y.clone()),
        switched: None,
    };
    let mut impacts = 0u64;
    let mut touching = chain.touching(&y.as_slice()[..dim]);
    obs.sample(
        0,
        0.0,
        &inst.cart.at_time(0.0),
        &y.as_slice()[..dim],
        chain,
        &mut ws,
    );
    let rows = plan.steps / plan.sample_every;
    let row_dt = plan.sample_every as f64 * plan.dt_s;
    let mut t = 0.0;
    let poll_s = POLL_STEPS as f64 * plan.dt_s;
    for row in 1..=rows {
        let t_row = row as f64 * row_dt;
        while t < t_row {
            if t > 0.0 && obs.poll((t / plan.dt_s) as u64) {
                return Ok(Outcome {
                    status: Status::Ok,
                    steps_done: (t / plan.dt_s) as u64,
                    impacts,
                    failed_at_s: None,
                    substeps: None,
                });
            }
            piece.watch = true;
            let t_goal = t_row.min(t + poll_s);
            let (t_end, y_end) = run_piece(&mut piece, t, &y, t_goal, opts)?;
            match piece.switched.take() {
                None => {
                    t = t_goal.max(t_end);
                    y = y_end;
                }
                Some((t_hit, _)) => {
                    let (t_lo, y_lo) = piece.last_ok.clone();
                    let (t_sw, y_sw) = locate_switch(&mut piece, t_lo, &y_lo, t_hit, opts)?;
                    t = t_sw;
                    y = y_sw;
                    piece.mode = chain.bumper_modes(&mut ws, &y.as_slice()[..dim]);
                }
            }
            let now = chain.touching(&y.as_slice()[..dim]);
            impacts += u64::from(now.0 && !touching.0) + u64::from(now.1 && !touching.1);
            touching = now;
        }
        let cart = inst.cart.at_time(t_row);
        let status = inst.guard.check(chain, &y.as_slice()[..dim], cart.v_m_s);
        if status != Status::Ok {
            return Ok(Outcome {
                status,
                steps_done: row * plan.sample_every,
                impacts,
                failed_at_s: Some(t_row),
                substeps: None,
            });
        }
        obs.sample(
            row * plan.sample_every,
            t_row,
            &cart,
            &y.as_slice()[..dim],
            chain,
            &mut ws,
        );
        if obs.stopped() {
            return Ok(Outcome {
                status: Status::Ok,
                steps_done: row * plan.sample_every,
                impacts,
                failed_at_s: None,
                substeps: None,
            });
        }
    }
    Ok(Outcome {
        status: Status::Ok,
        steps_done: rows * plan.sample_every,
        impacts,
        failed_at_s: None,
        substeps: None,
    })
}

/// Bisect the first time in (t_lo, t_hi] at which the exact law's engagement differs from the
/// frozen one. Returns the state just after the switch.
fn locate_switch(
    piece: &mut Piece<'_>,
    mut t_lo: f64,
    y_lo: &DVector<f64>,
    mut t_hi: f64,
    opts: &ReferenceOptions,
) -> Result<(f64, DVector<f64>), EngineError> {
    piece.watch = false;
    let mut y_lo = y_lo.clone();
    let mut y_hi = run_piece(piece, t_lo, &y_lo, t_hi, opts)?.1;
    let mut ws = piece.chain.workspace();
    for _ in 0..80 {
        if t_hi - t_lo <= 1e-13 * t_hi.abs().max(1.0) {
            break;
        }
        let t_mid = 0.5 * (t_lo + t_hi);
        let y_mid = run_piece(piece, t_lo, &y_lo, t_mid, opts)?.1;
        let dim = y_mid.len() - 1;
        if piece.chain.bumper_modes(&mut ws, &y_mid.as_slice()[..dim]) != piece.mode {
            t_hi = t_mid;
            y_hi = y_mid;
        } else {
            t_lo = t_mid;
            y_lo = y_mid;
        }
    }
    piece.watch = true;
    Ok((t_hi, y_hi))
}
