//! The axes of a heat map over a grid of cell centres: where the cells end ([`cell_edges`],
//! [`log_cell_edges`]) and which round values are ticked, on a linear or a log scale
//! ([`AxisScale`]); shared by the PNG maps and the explorer ([`grid_axis`]).
//!
//! A log axis (centres > 0) is drawn in plotting space `log10(v)`: its cells end at the
//! geometric midpoints of the centres, and its ticks are decades (with minor ticks at
//! 2…9 × 10^k), 1, 2 and 5 × 10^k over one to three decades, or round values within less
//! than one ([`AxisSpec::fixed`]). A linear axis is drawn as it always was.

use pendulum_atlas_core::config::AxisScale;

use super::AxisSpec;

/// Half the width (decades) of the cell of a single centre on a log axis.
const LOG_SINGLE_HALF_DECADES: f64 = 0.05;

/// Cell boundaries of a linear axis: midpoints `(c_i + c_{i+1}) / 2` between centres, the ends
/// extended by half a step, `c_0 − (c_1 − c_0)/2` and `c_{n−1} + (c_{n−1} − c_{n−2})/2`; a
/// single centre `c` spans `c ∓ 0.1·|c|` (`∓ 0.5` for `c = 0`).
pub(crate) fn cell_edges(c: &[f64]) -> Vec<f64> {
    if c.len() == 1 {
        let d = if c[0] == 0.0 { 0.5 } else { 0.1 * c[0].abs() };
        return vec![c[0] - d, c[0] + d];
    }
    let n = c.len();
    let mut e = Vec::with_capacity(n + 1);
    e.push(c[0] - 0.5 * (c[1] - c[0]));
    e.extend(c.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    e.push(c[n - 1] + 0.5 * (c[n - 1] - c[n - 2]));
    e
}

/// Cell boundaries of a log axis (centres > 0): geometric midpoints `√(c_i·c_{i+1})`, the ends
/// extended by half a step in log, `c_0·√(c_0/c_1)` and `c_{n−1}·√(c_{n−1}/c_{n−2})`, so every
/// edge is > 0; a single centre `c` spans `c·10^(∓0.05)`.
pub(crate) fn log_cell_edges(c: &[f64]) -> Vec<f64> {
    if c.len() == 1 {
        let f = 10f64.powf(LOG_SINGLE_HALF_DECADES);
        return vec![c[0] / f, c[0] * f];
    }
    let n = c.len();
    let mut e = Vec::with_capacity(n + 1);
    e.push(c[0] * (c[0] / c[1]).sqrt());
    e.extend(c.windows(2).map(|w| (w[0] * w[1]).sqrt()));
    e.push(c[n - 1] * (c[n - 1] / c[n - 2]).sqrt());
    e
}

/// Whether centres `values` on `scale` are drawn in log space: a log axis whose values are all
/// > 0 (the first, values increasing). A log axis reaching 0 or below is drawn linear.
pub(crate) fn drawn_log(values: &[f64], scale: AxisScale) -> bool {
    scale == AxisScale::Log && values.first().is_some_and(|&v| v > 0.0)
}

/// Cell edges of centres `values` in data space: [`log_cell_edges`] when drawn in log,
/// else [`cell_edges`].
fn data_edges(values: &[f64], log: bool) -> Vec<f64> {
    if log {
        log_cell_edges(values)
    } else {
        cell_edges(values)
    }
}

/// The cell edges of centres `values` in plotting space (`log10` of the data edges when drawn
/// in log) and the axis over them, with its round ticks (a single cell: one tick at its
/// centre, no minor ones).
pub(crate) fn grid_spec(values: &[f64], scale: AxisScale) -> (Vec<f64>, AxisSpec) {
    let log = drawn_log(values, scale);
    let mut edges = data_edges(values, log);
    if log {
        edges.iter_mut().for_each(|e| *e = e.log10());
    }
    let n = values.len();
    let mut axis = AxisSpec::fixed(edges[0], edges[n], log);
    if n == 1 {
        axis.ticks = vec![if log { values[0].log10() } else { values[0] }];
        axis.minor.clear();
    }
    (edges, axis)
}

/// A map axis as the heatmaps draw it, for drawing it elsewhere (the explorer): its cell
/// edges and its ticks, in data space.
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    /// Cell edges: midpoints between centres, the ends half a step out (geometric midpoints
    /// and steps on a log axis).
    pub edges: Vec<f64>,
    /// Round values within the edges, labelled (a single cell: its centre).
    pub ticks: Vec<(f64, String)>,
    /// Unlabelled minor ticks (2…9 × 10^k on a log axis over a few decades; else none).
    pub minor: Vec<f64>,
    /// Drawn in log space (a log axis with values > 0).
    pub log: bool,
}

impl GridAxis {
    /// Where value `v` lies, in cells from the first edge: cell `i` plus the fraction
    /// `(p(v) − p(e_i)) / (p(e_{i+1}) − p(e_i))` of it, `p` = `log10` on a log axis, else the
    /// identity; the first and last cells extend beyond the edges. The explorer draws equal
    /// cells and places ticks here.
    pub fn at(&self, v: f64) -> f64 {
        let p = |x: f64| if self.log { x.log10() } else { x };
        let e = &self.edges;
        let i = e[1..e.len() - 1].partition_point(|&x| x <= v);
        i as f64 + (p(v) - p(e[i])) / (p(e[i + 1]) - p(e[i]))
    }
}

/// The axis of a map over cell centres `values` on `scale`, as [`super::heatmap_scaled`]
/// draws it.
pub fn grid_axis(values: &[f64], scale: AxisScale) -> GridAxis {
    let (_, axis) = grid_spec(values, scale);
    let log = drawn_log(values, scale);
    let data = |t: f64| if log { 10f64.powf(t) } else { t };
    GridAxis {
        edges: data_edges(values, log),
        ticks: axis
            .ticks
            .iter()
            .map(|&t| (data(t), axis.label(t)))
            .collect(),
        minor: axis.minor.iter().map(|&t| data(t)).collect(),
        log,
    }
}

/// Index of the cell of `v` given the edges (None outside).
pub(crate) fn cell_of(edges: &[f64], v: f64) -> Option<usize> {
    if !(v >= edges[0] && v <= edges[edges.len() - 1]) {
        return None;
    }
    Some(edges.partition_point(|&e| e <= v).clamp(1, edges.len() - 1) - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
    }

    fn labels(g: &GridAxis) -> Vec<&str> {
        g.ticks.iter().map(|(_, l)| l.as_str()).collect()
    }

    #[test]
    fn a_log_axis_is_drawn_with_geometric_cell_edges() {
        let g = grid_axis(&[1.0, 10.0, 100.0], AxisScale::Log);
        let want = [
            10f64.powf(-0.5),
            10f64.powf(0.5),
            10f64.powf(1.5),
            10f64.powf(2.5),
        ];
        assert!(g.log);
        assert_eq!(g.edges.len(), want.len());
        for (e, w) in g.edges.iter().zip(want) {
            assert!(close(*e, w), "{:?} != {want:?}", g.edges);
        }
        // Decades labelled, 2…9 × 10^k unlabelled between them.
        assert_eq!(labels(&g), ["1", "10", "100"]);
        assert!(g.minor.iter().any(|&m| close(m, 2.0)) && g.minor.iter().any(|&m| close(m, 90.0)));
        assert!(g.minor.iter().all(|&m| m > g.edges[0] && m < g.edges[3]));
    }

    #[test]
    fn a_log_axis_starting_near_zero_keeps_every_edge_positive() {
        // Linear midpoints would put the first edge at 0.001 − 0.5·(1 − 0.001) < 0.
        let g = grid_axis(&[0.001, 1.0, 1000.0], AxisScale::Log);
        assert!(g.edges.iter().all(|&e| e > 0.0), "{:?}", g.edges);
        assert!(close(g.edges[0], 0.001 * 0.001f64.sqrt()));
        let lin = grid_axis(&[0.001, 1.0, 1000.0], AxisScale::Linear);
        assert!(lin.edges[0] < 0.0 && !lin.log);
    }

    #[test]
    fn a_log_axis_of_geometric_centres_has_cells_of_equal_width_in_the_picture() {
        let c: Vec<f64> = (0..6).map(|i| 2.0 * 3f64.powi(i)).collect();
        let (edges, axis) = grid_spec(&c, AxisScale::Log);
        let w: Vec<f64> = edges.windows(2).map(|p| p[1] - p[0]).collect();
        assert!(w.iter().all(|&x| close(x, w[0])), "{w:?}");
        assert_eq!(
            (axis.lo, axis.hi, axis.base),
            (edges[0], edges[6], Some(10.0))
        );
    }

    #[test]
    fn a_log_axis_over_little_more_than_a_decade_labels_2_and_5() {
        let c: Vec<f64> = (0..6).map(|i| 20f64.powf(i as f64 / 5.0)).collect();
        let g = grid_axis(&c, AxisScale::Log);
        assert_eq!(labels(&g), ["1", "2", "5", "10", "20"]);
        let c: Vec<f64> = (0..6).map(|i| 4.0 * 3f64.powf(i as f64 / 5.0)).collect();
        let g = grid_axis(&c, AxisScale::Log);
        assert_eq!(labels(&g), ["4", "6", "8", "10", "12"]);
    }

    #[test]
    fn ticks_of_a_log_axis_lie_at_their_log_position_in_the_cells() {
        let g = grid_axis(&[1.0, 10.0, 100.0], AxisScale::Log);
        assert!(close(g.at(1.0), 0.5) && close(g.at(10.0), 1.5) && close(g.at(100.0), 2.5));
        assert!(close(g.at(g.edges[0]), 0.0) && close(g.at(g.edges[3]), 3.0));
        let lin = grid_axis(&[5.0, 6.0, 7.0], AxisScale::Linear);
        assert!(close(lin.at(6.25), 1.75));
    }

    #[test]
    fn a_linear_axis_keeps_arithmetic_edges_and_round_ticks() {
        let c = [5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        let g = grid_axis(&c, AxisScale::Linear);
        assert_eq!(g.edges, [4.5, 5.5, 6.5, 7.5, 8.5, 9.5, 10.5]);
        assert_eq!(labels(&g), ["5", "6", "7", "8", "9", "10"]);
        assert!(g.minor.is_empty() && !g.log);
        assert_eq!(grid_spec(&c, AxisScale::Linear).0, g.edges);
    }

    #[test]
    fn a_log_axis_reaching_zero_is_drawn_linear_and_a_single_cell_is_ticked_at_its_centre() {
        assert_eq!(
            grid_axis(&[0.0, 1.0, 2.0], AxisScale::Log),
            grid_axis(&[0.0, 1.0, 2.0], AxisScale::Linear)
        );
        let g = grid_axis(&[50.0], AxisScale::Log);
        assert!(g.edges[0] > 0.0 && g.edges[0] < 50.0 && g.edges[1] > 50.0);
        assert_eq!(labels(&g), ["50"]);
        assert!(close(g.ticks[0].0, 50.0) && g.minor.is_empty());
    }
}
