//! Globally adaptive Gauss–Kronrod quadrature (G10/K21, QUADPACK's `qk21` nodes) in f64.
//!
//! Error model, per accepted panel: |K21 − G10| plus the K21-weighted error of the integrand
//! values (non-zero for a nested integral). |K − G| estimates the error of the 10-point
//! Gauss rule, while the returned value is the far more accurate Kronrod one, so the sum is
//! conservative; we keep it raw rather than QUADPACK's `(200|K−G|/resasc)^1.5` rescaling,
//! which is smaller exactly where a reference should not gamble. On top of that a rounding
//! floor `nodes·ε·∫|f|` bounds what summing `nodes` rounded values can lose.

use std::cell::RefCell;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// An integral with its absolute error estimate and the integral of its absolute value.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Quad {
    pub value: f64,
    pub error: f64,
    pub abs: f64,
}

impl Quad {
    /// An integrand value known to working precision (its rounding is in the floor).
    pub fn exact(value: f64) -> Quad {
        Quad {
            value,
            error: 0.0,
            abs: value.abs(),
        }
    }

    pub fn scale(self, s: f64) -> Quad {
        Quad {
            value: self.value * s,
            error: self.error * s.abs(),
            abs: self.abs * s.abs(),
        }
    }
}

impl std::ops::Add for Quad {
    type Output = Quad;
    fn add(self, o: Quad) -> Quad {
        Quad {
            value: self.value + o.value,
            error: self.error + o.error,
            abs: self.abs + o.abs,
        }
    }
}

impl std::ops::AddAssign for Quad {
    fn add_assign(&mut self, o: Quad) {
        *self = *self + o;
    }
}

/// Positive K21 abscissae on [−1, 1]; odd indices are the G10 nodes, the last is the centre.
/// QUADPACK's 33-digit constants, kept verbatim.
#[allow(clippy::excessive_precision)]
const XGK: [f64; 11] = [
    0.995657163025808080735527280689003,
    0.973906528517171720077964012084452,
    0.930157491355708226001207180059508,
    0.865063366688984510732096688423493,
    0.780817726586416897063717578345042,
    0.679409568299024406234327365114874,
    0.562757134668604683339000099272694,
    0.433395394129247190799265943165784,
    0.294392862701460198131126603103866,
    0.148874338981631210884826001129720,
    0.0,
];
#[allow(clippy::excessive_precision)]
const WGK: [f64; 11] = [
    0.011694638867371874278064396062192,
    0.032558162307964727478818972459390,
    0.054755896574351996031381300244580,
    0.075039674810919952767043140916190,
    0.093125454583697605535065465083366,
    0.109387158802297641899210590325805,
    0.123491976262065851077958109831074,
    0.134709217311473325928054001771707,
    0.142775938577060080797094273138717,
    0.147739104901338491374841515972068,
    0.149445554002916905664936468389821,
];
/// G10 weights of XGK[1], XGK[3], …, XGK[9].
#[allow(clippy::excessive_precision)]
const WG: [f64; 5] = [
    0.066671344308688137593568809893332,
    0.149451349150580593145776339657697,
    0.219086362515982043995534934228163,
    0.269266719309996355091226921569469,
    0.295524224714752870173892994651338,
];
pub(crate) const NODES: usize = 21;

/// A panel `[start, start + len]`. The length is kept apart from the end point so that a
/// short panel far from 0 keeps its length to full relative precision.
#[derive(Clone, Copy, Debug)]
struct Panel {
    start: f64,
    len: f64,
    q: Quad,
}

impl PartialEq for Panel {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Panel {}
impl PartialOrd for Panel {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Panel {
    /// The heap pops the panel with the largest error first.
    fn cmp(&self, o: &Self) -> Ordering {
        self.q.error.total_cmp(&o.q.error)
    }
}

/// The 21 nodes of the panel centred at `centre` with half-length `half`: the centre first,
/// then `centre ∓ half·XGK[j]` for j = 0..10 (lower then upper).
#[inline]
fn nodes(centre: f64, half: f64) -> [f64; NODES] {
    let mut x = [centre; NODES];
    for j in 0..10 {
        let dx = half * XGK[j];
        x[1 + 2 * j] = centre - dx;
        x[2 + 2 * j] = centre + dx;
    }
    x
}

/// A batch integrand: the values at the 21 nodes of a panel, in the order of [`nodes`].
pub(crate) type Batch<'a> = dyn FnMut(&[f64; NODES], &mut [Quad; NODES]) + 'a;

fn kronrod(f: &mut Batch, start: f64, len: f64) -> Panel {
    let half = 0.5 * len;
    let centre = start + half;
    let mut v = [Quad::default(); NODES];
    f(&nodes(centre, half), &mut v);
    let fc = v[0];
    let mut k = WGK[10] * fc.value;
    let mut g = 0.0;
    let mut inner = WGK[10] * fc.error;
    let mut abs = WGK[10] * fc.abs;
    for j in 0..10 {
        let (lo, hi) = (v[1 + 2 * j], v[2 + 2 * j]);
        let sum = lo.value + hi.value;
        k += WGK[j] * sum;
        if j % 2 == 1 {
            g += WG[j / 2] * sum;
        }
        inner += WGK[j] * (lo.error + hi.error);
        abs += WGK[j] * (lo.abs + hi.abs);
    }
    let h = half.abs();
    Panel {
        start,
        len,
        q: Quad {
            value: k * half,
            error: (k - g).abs() * h + inner * h,
            abs: abs * h,
        },
    }
}

/// Integrates `f` over the union of `panels` (`(start, len)`, disjoint), bisecting the panel
/// with the largest error until the total error is below `rtol·|value|` or the rounding
/// floor, or `max_panels` panels are in use; in that case the error returned is what is
/// left, so a capped integral says so.
pub(crate) fn integrate(mut f: impl FnMut(f64) -> Quad, panels: &[(f64, f64)], rtol: f64, max_panels: usize) -> Quad {
    integrate_batch(
        &mut |x: &[f64; NODES], out: &mut [Quad; NODES]| {
            for (o, &x) in out.iter_mut().zip(x) {
                *o = f(x);
            }
        },
        panels,
        rtol,
        max_panels,
    )
}

/// [`integrate`] with an integrand that takes a panel's 21 nodes at once (see [`nodes`]):
/// the same panels, sums and result as node by node.
pub(crate) fn integrate_batch(f: &mut Batch, panels: &[(f64, f64)], rtol: f64, max_panels: usize) -> Quad {
    integrate_batch_within(f, panels, rtol, 0.0, max_panels)
}

/// [`integrate_batch`] that also stops once the total error is below `atol` (absolute): for
/// an inner integral whose value counts only as a part of an outer one, which sets `atol`
/// from its own scale (`surface.rs`). The error returned is the estimate, as always: a
/// looser stop is paid for in the outer integral's error, never hidden.
pub(crate) fn integrate_batch_within(
    f: &mut Batch,
    panels: &[(f64, f64)],
    rtol: f64,
    atol: f64,
    max_panels: usize,
) -> Quad {
    // The heap's storage comes from a per-thread pool (nested integrals take one each) rather
    // than an allocation per call; it is returned empty.
    let mut heap = BinaryHeap::from(POOL.with(|p| p.borrow_mut().pop()).unwrap_or_default());
    heap.reserve(2 * panels.len() + 16);
    let mut total = Quad::default();
    for &(start, len) in panels {
        let p = kronrod(f, start, len);
        total += p.q;
        heap.push(p);
    }
    let floor = |total: &Quad, count: usize| (count * NODES) as f64 * f64::EPSILON * total.abs;
    let mut evaluated = panels.len();
    while total.error > (rtol * total.value.abs()).max(floor(&total, evaluated)).max(atol) && heap.len() < max_panels {
        let Some(worst) = heap.pop() else { break };
        let half = 0.5 * worst.len;
        let middle = worst.start + half;
        // Below this length the two halves would no longer have distinct nodes.
        if half.abs() <= 64.0 * f64::EPSILON * middle.abs() {
            heap.push(worst);
            break;
        }
        let (a, b) = (kronrod(f, worst.start, half), kronrod(f, middle, half));
        total.value += a.q.value + b.q.value - worst.q.value;
        total.error += a.q.error + b.q.error - worst.q.error;
        total.abs += a.q.abs + b.q.abs - worst.q.abs;
        evaluated += 2;
        heap.push(a);
        heap.push(b);
    }
    // Re-sum: the running totals above drift by cancellation.
    let mut sum = heap.iter().fold(Quad::default(), |s, p| s + p.q);
    sum.error += floor(&sum, evaluated);
    let mut storage = heap.into_vec();
    storage.clear();
    POOL.with(|p| {
        let mut pool = p.borrow_mut();
        if pool.len() < 8 {
            pool.push(storage);
        }
    });
    sum
}

thread_local! {
    /// Emptied heaps kept for the next integral on this thread.
    static POOL: RefCell<Vec<Vec<Panel>>> = const { RefCell::new(Vec::new()) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_are_exact_for_their_degree() {
        // K21 integrates degree 31 exactly, G10 degree 19: a typo in a constant breaks this.
        for k in 0..=31 {
            let p = kronrod(
                &mut |x: &[f64; NODES], out: &mut [Quad; NODES]| {
                    for (o, x) in out.iter_mut().zip(x) {
                        *o = Quad::exact(x.powi(k));
                    }
                },
                0.0,
                1.0,
            );
            let exact = 1.0 / (k as f64 + 1.0);
            assert!((p.q.value - exact).abs() < 1e-15, "K21 x^{k}: {}", p.q.value);
            if k <= 19 {
                assert!(p.q.error < 1e-15, "G10 x^{k}: {}", p.q.error);
            }
        }
    }

    #[test]
    fn adaptive_resolves_a_sharp_peak_and_reports_honest_error() {
        // ∫_{-1}^{1} w/(w²+x²) dx = 2 atan(1/w).
        for w in [1e-1, 1e-3, 1e-5] {
            let q = integrate(|x| Quad::exact(w / (w * w + x * x)), &[(-1.0, 2.0)], 1e-13, 2000);
            let exact = 2.0 * (1.0 / w).atan();
            let err = (q.value - exact).abs();
            assert!(err <= q.error, "w={w}: err {err:e} > estimate {:e}", q.error);
            assert!(err < 1e-12 * exact, "w={w}: err {err:e}");
        }
    }

    #[test]
    fn an_absolute_tolerance_stops_earlier_and_stays_honest() {
        // ∫_{-1}^{1} w/(w²+x²) dx = 2 atan(1/w) with a sharp peak: `atol` = 0 is
        // `integrate_batch` bit for bit; an `atol` far above rtol·value stops with fewer
        // panels, its error at most `atol` and still covering the true error.
        let w: f64 = 1e-3;
        let exact = 2.0 * (1.0 / w).atan();
        let run = |atol: f64| {
            let mut calls = 0;
            let mut f = |x: &[f64; NODES], out: &mut [Quad; NODES]| {
                calls += 1;
                for (o, &x) in out.iter_mut().zip(x) {
                    *o = Quad::exact(w / (w * w + x * x));
                }
            };
            let q = integrate_batch_within(&mut f, &[(-1.0, 2.0)], 1e-13, atol, 2000);
            (q, calls)
        };
        let (tight, tight_calls) = run(0.0);
        let plain = integrate_batch(
            &mut |x: &[f64; NODES], out: &mut [Quad; NODES]| {
                for (o, &x) in out.iter_mut().zip(x) {
                    *o = Quad::exact(w / (w * w + x * x));
                }
            },
            &[(-1.0, 2.0)],
            1e-13,
            2000,
        );
        assert_eq!(tight, plain);
        let atol = 1e-6 * exact;
        let (loose, loose_calls) = run(atol);
        assert!(loose_calls < tight_calls, "{loose_calls} {tight_calls}");
        assert!(loose.error > tight.error && loose.error <= atol, "{loose:?}");
        assert!((loose.value - exact).abs() <= loose.error, "{loose:?} vs {exact}");
        assert!((tight.value - exact).abs() <= tight.error, "{tight:?} vs {exact}");
    }

    #[test]
    fn capped_integral_reports_what_is_left() {
        // A jump at an irrational point cannot be resolved in 4 panels: the estimate must say so.
        let x0 = 0.1f64.sqrt();
        let q = integrate(|x| Quad::exact(if x < x0 { 1.0 } else { 0.0 }), &[(0.0, 1.0)], 1e-13, 4);
        assert!((q.value - x0).abs() <= q.error && q.error > 1e-6, "{q:?}");
    }
}
