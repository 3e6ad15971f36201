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

/// The cost of the cheapest uniform cut whose p99 is at most `p99_px`, interpolated linearly
/// (in p99) between the two neighbouring points of `curve` (any order; sorted by nodes here).
/// Going up in nodes, the first point at or under the error and the one before it bracket it.
/// If the cheapest point already meets it, that point is returned: the curve says nothing about
/// cheaper cuts, so a ratio against it is a bound in the uniform cut's favour. `None` when no
/// point meets the error or `p99_px` is not finite.
pub fn uniform_cost_at(curve: &[CostPoint], p99_px: f64) -> Option<CostPoint> {
    if !p99_px.is_finite() {
        return None;
    }
    let mut points = curve.to_vec();
    points.sort_by(|a, b| a.nodes.total_cmp(&b.nodes));
    let i = points.iter().position(|p| p.p99_px <= p99_px)?;
    if i == 0 {
        return Some(points[0]);
    }
    let (a, b) = (points[i - 1], points[i]);
    let span = a.p99_px - b.p99_px;
    let f = if span > 0.0 {
        ((a.p99_px - p99_px) / span).clamp(0.0, 1.0)
    } else {
        1.0
    };
    Some(CostPoint {
        nodes: a.nodes + f * (b.nodes - a.nodes),
        ms: a.ms + f * (b.ms - a.ms),
        p99_px,
    })
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
    fn a_non_monotone_curve_takes_the_first_crossing() {
        // A dip at 200 nodes: 3 px is first met there, between 100 and 200 nodes.
        let curve = [
            point(100.0, 1.0, 5.0),
            point(200.0, 2.0, 1.0),
            point(300.0, 3.0, 4.0),
        ];
        let c = uniform_cost_at(&curve, 3.0).unwrap();
        assert!((c.nodes - 150.0).abs() < 1e-9, "{c:?}");
    }
}
