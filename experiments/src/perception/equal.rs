//! Equal error: what a uniform cut costs at the error the feedback loop reaches. Uniform cuts at
//! several node counts give a cost–error curve; the uniform cost at the feedback run's measured
//! p99 is interpolated on it, and the cost ratio is feedback's cost over that.

/// One point of a cost–error curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostPoint {
    /// Mean simulated nodes.
    pub nodes: f64,
    /// Cost per frame (step + evaluation + reconstruction), ms.
    pub ms: f64,
    /// On-screen p99 error, px.
    pub p99_px: f64,
}

/// The cheapest cost at which `curve` (uniform cuts, any order) reaches `p99_px`: the least
/// `ms` among its points at or under the error and the points where a segment between two
/// neighbouring points (sorted by nodes) crosses it, interpolated linearly in p99. Cost need not
/// grow with nodes (the full-resolution cloth needs no reconstruction, so it may be cheaper
/// than a reduced cut), hence the minimum rather than the first crossing. If the cheapest point
/// meets the error, the curve says nothing about cheaper cuts and that point is the answer, a
/// bound in the uniform cut's favour. `None` when no point meets the error or `p99_px` is not
/// finite.
pub fn uniform_cost_at(curve: &[CostPoint], p99_px: f64) -> Option<CostPoint> {
    if !p99_px.is_finite() {
        return None;
    }
    let mut points = curve.to_vec();
    points.sort_by(|a, b| a.nodes.total_cmp(&b.nodes));
    let mut candidates: Vec<CostPoint> = points
        .iter()
        .copied()
        .filter(|p| p.p99_px <= p99_px)
        .collect();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if (a.p99_px - p99_px) * (b.p99_px - p99_px) < 0.0 {
            let f = (a.p99_px - p99_px) / (a.p99_px - b.p99_px);
            candidates.push(CostPoint {
                nodes: a.nodes + f * (b.nodes - a.nodes),
                ms: a.ms + f * (b.ms - a.ms),
                p99_px,
            });
        }
    }
    candidates.into_iter().min_by(|a, b| a.ms.total_cmp(&b.ms))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(nodes: f64, ms: f64, p99_px: f64) -> CostPoint {
        CostPoint { nodes, ms, p99_px }
    }

    #[test]
    fn interpolates_between_the_bracketing_points() {
        // Error halves as nodes double, cost linear in nodes; given out of order.
        let curve = [
            point(400.0, 0.4, 2.0),
            point(100.0, 0.1, 8.0),
            point(800.0, 0.8, 1.0),
            point(200.0, 0.2, 4.0),
        ];
        // 3 px lies halfway between 4 px (200 nodes) and 2 px (400 nodes).
        let c = uniform_cost_at(&curve, 3.0).unwrap();
        assert!((c.nodes - 300.0).abs() < 1e-9, "{c:?}");
        assert!((c.ms - 0.3).abs() < 1e-12, "{c:?}");
        // A point of the curve is itself.
        let c = uniform_cost_at(&curve, 2.0).unwrap();
        assert!((c.nodes - 400.0).abs() < 1e-9, "{c:?}");
        // Easier than the cheapest point: the cheapest point (a bound).
        assert_eq!(uniform_cost_at(&curve, 50.0).unwrap().nodes, 100.0);
        // Harder than every point, or not a number: none.
        assert!(uniform_cost_at(&curve, 0.5).is_none());
        assert!(uniform_cost_at(&curve, f64::NAN).is_none());
        assert!(uniform_cost_at(&[], 1.0).is_none());
    }

    #[test]
    fn the_cheapest_crossing_wins_when_cost_is_not_monotone() {
        // A dip at 200 nodes: 3 px is crossed between 100 and 200 nodes and again between 200
        // and 300; the first crossing is the cheaper.
        let curve = [
            point(100.0, 1.0, 5.0),
            point(200.0, 2.0, 1.0),
            point(300.0, 3.0, 4.0),
        ];
        let c = uniform_cost_at(&curve, 3.0).unwrap();
        assert!((c.nodes - 150.0).abs() < 1e-9, "{c:?}");
        // A full-resolution point cheaper than the reduced cuts near it (no reconstruction):
        // it is the answer wherever the reduced cuts would cost more.
        let curve = [
            point(100.0, 1.0, 8.0),
            point(300.0, 3.0, 4.0),
            point(400.0, 2.5, 0.0),
        ];
        let c = uniform_cost_at(&curve, 4.0).unwrap();
        assert_eq!((c.nodes, c.ms), (400.0, 2.5));
        // Between 8 and 4 px the crossing on the first segment is cheaper.
        let c = uniform_cost_at(&curve, 6.0).unwrap();
        assert!(
            (c.ms - 2.0).abs() < 1e-12 && (c.nodes - 200.0).abs() < 1e-9,
            "{c:?}"
        );
    }
}
