//! The Pareto front of cost against error: the methods no other method beats on both at once
//! (the speed-against-accuracy chart draws it, the cost section names its members).

use crate::analyse::summary::ChartPoint;

/// A cost a log axis can place and a front can compare: positive and finite.
pub fn valid_cost(cost: f64) -> bool {
    cost.is_finite() && cost > 0.0
}

/// Indices (ascending) of the points on the Pareto front of cost against error (the p99 when
/// `by_p99`, else the median): those that no other point dominates, i.e. no other point is
/// both cheaper-or-equal and more-accurate-or-equal while strictly better in one of the two.
/// Exact ties are all on the front. A point whose cost is not a positive finite number or whose
/// error is not a finite non-negative number is never on the front, and dominates nothing.
pub fn pareto_front(points: &[ChartPoint], by_p99: bool) -> Vec<usize> {
    let keys: Vec<Option<(f64, f64)>> = points
        .iter()
        .map(|p| {
            let error = if by_p99 { p.p99 } else { p.median };
            (valid_cost(p.cost) && error.is_finite() && error >= 0.0).then_some((p.cost, error))
        })
        .collect();
    let dominates = |(cj, ej): (f64, f64), (ci, ei): (f64, f64)| cj <= ci && ej <= ei && (cj < ci || ej < ei);
    (0..points.len())
        .filter(|&i| keys[i].is_some_and(|ki| !keys.iter().any(|kj| kj.is_some_and(|kj| dominates(kj, ki)))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(label: &str, cost: f64, median: f64, p99: f64) -> ChartPoint {
        let group = label.split('@').next().unwrap().to_string();
        ChartPoint {
            label: label.into(),
            group,
            cost,
            median,
            p99,
        }
    }

    #[test]
    fn pareto_front_excludes_dominated_points_and_keeps_ties() {
        let points = vec![
            pt("a", 1.0, 1e-3, 1e-2),         // 0: cheapest
            pt("b", 1.0, 1e-3, 2e-2),         // 1: same cost as a, worse p99: dominated
            pt("c", 2.0, 1e-4, 1e-3),         // 2: front
            pt("d", 2.0, 1e-4, 1e-3),         // 3: exact tie with c: both on the front
            pt("e", 3.0, 1e-5, 5e-3),         // 4: dearer and worse p99 than c: dominated (best median)
            pt("f", 5.0, 1e-6, 1e-3),         // 5: same p99 as c, dearer: dominated
            pt("g", 4.0, 1e-5, f64::NAN),     // 6: no p99: never on the front
            pt("h", 8.0, 1e-7, 0.0),          // 7: exact: front
            pt("i", f64::NAN, 0.0, 0.0),      // 8: no cost: never, and dominates nothing
            pt("j", 9.0, 0.0, 0.0),           // 9: dominated by h (same error, dearer)
            pt("k", 0.5, 0.5, f64::INFINITY), // 10: cheapest but infinite p99: never
        ];
        assert_eq!(pareto_front(&points, true), vec![0, 2, 3, 7]);
        // By median: a and b tie, e and f are now the best for their cost, g is dominated by
        // e, j (exact) beats h, and k is cheapest with a finite median.
        assert_eq!(pareto_front(&points, false), vec![0, 1, 2, 3, 4, 5, 7, 9, 10]);
        assert_eq!(pareto_front(&[], true), Vec::<usize>::new());
    }
}
