//! The cart's acceleration of each lane of a group at the stages of every step of one
//! forcing period, read from a table instead of a `sin` per lane and stage: the fixed-step
//! lanes' steps, and the base-level sub-steps of the ladder's.

use crate::engine::plan::InstancePlan;
use crate::model::Lane;

/// The cart's acceleration (m/s²) of each lane at every step of a forcing period and stage
/// fraction: `table[lane][(step mod spp) · stages + j]`, exactly `cart_at(step, c_j)`; with
/// each lane's current `step mod spp`, advanced step by step.
#[derive(Clone)]
pub(super) struct CartTable {
    stages: usize,
    spp: Vec<usize>,
    table: Vec<Vec<f64>>,
    phase: Vec<usize>,
}

impl CartTable {
    pub(super) fn new(plans: &[&InstancePlan], fracs: &[f64]) -> CartTable {
        let table = plans
            .iter()
            .map(|p| {
                (0..u64::from(p.spp))
                    .flat_map(|k| fracs.iter().map(move |&c| p.cart_at(k, c).a_m_s2))
                    .collect()
            })
            .collect();
        CartTable {
            stages: fracs.len(),
            spp: plans.iter().map(|p| p.spp as usize).collect(),
            table,
            phase: vec![0; plans.len()],
        }
    }

    /// The acceleration of every lane at stage `j` of the current step.
    #[inline]
    pub(super) fn at<V: Lane>(&self, j: usize) -> V {
        V::gather(|i| {
            let l = i % self.spp.len();
            self.table[l][self.phase[l] * self.stages + j]
        })
    }

    /// On to the next step.
    #[inline]
    pub(super) fn advance(&mut self) {
        for (ph, &spp) in self.phase.iter_mut().zip(&self.spp) {
            *ph += 1;
            if *ph == spp {
                *ph = 0;
            }
        }
    }

    /// Lane `l`'s acceleration at stage `j` of its step `step` (any step: the lanes of a
    /// ladder each keep their own), exactly `cart_at(step, c_j)`.
    #[inline]
    pub(super) fn at_lane(&self, l: usize, step: u64, j: usize) -> f64 {
        let phase = (step % self.spp[l] as u64) as usize;
        self.table[l][phase * self.stages + j]
    }
}
