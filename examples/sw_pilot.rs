//! The pilot behind `sw::PARAMS` (the anisotropic table's SW fit): five entries of the 8⁴ table fitted with the SW
//! objective from diag(αx, αy, 1), with the learning rate, steps and samples per step given on the
//! command line (default 0.5, 2000, 128), beside the committed L1 entries: time, the L1 lobe error
//! (32² grid) and the SW distance (4096 samples × 256 directions) of both.
//! `cargo run --release --example sw_pilot -- 0.5 2000 128`
use linelight::input::ltc::{aniso, fit, sw};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lr: f64 = args.get(1).map_or(0.5, |s| s.parse().unwrap());
    let steps: usize = args.get(2).map_or(2000, |s| s.parse().unwrap());
    let samples: usize = args.get(3).map_or(128, |s| s.parse().unwrap());
    let t = aniso::ours();
    let size = t.size;
    for i in [
        [4usize, 3, 7, 0],
        [4, 3, 3, 0],
        [6, 3, 1, 0],
        [2, 0, 5, 7],
        [7, 7, 2, 3],
    ] {
        let p = aniso::entry_point(size, i);
        let g = aniso::lobe(p);
        let e = &t.entries[aniso::index(size, i)];
        let (mag, _, _) = g.moments(fit::MOMENT_GRID);
        let start = e.m; // warm from the L1 answer itself? no: from identity-ish
        let id = [[g.ax, 0.0, 0.0], [0.0, g.ay, 0.0], [0.0, 0.0, 1.0]];
        let _ = start;
        let t0 = std::time::Instant::now();
        let params = sw::Params {
            steps,
            directions: 64,
            samples,
            learning_rate: lr,
        };
        let (m, tail) = sw::fit(&g, &id, &params, 7);
        let secs = t0.elapsed().as_secs_f64();
        let (_, l1_sw) = fit::errors(&g, &fit::Ltc::new(m), mag, fit::OBJECTIVE_GRID);
        let d_sw = sw::distance(&g, &m, 4096, 256, 1);
        let d_l1 = sw::distance(&g, &e.m, 4096, 256, 1);
        println!("{i:?} p={p:.3?} secs {secs:.2} tail {tail:.4e} L1: sw {l1_sw:.4} table {:.4}  SW: sw {d_sw:.4e} table {d_l1:.4e}", e.l1);
    }
}
