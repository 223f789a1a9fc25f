use linelight::ltc::ggx::Ggx;
fn main() {
    for (alpha, ct) in [(0.0816f64, 1.0f64), (0.3265, 0.49), (0.3265, 0.000796), (1e-4, 0.000796)] {
        let g = Ggx { ax: alpha, ay: alpha, view: [(1.0 - ct * ct).sqrt(), 0.0, ct] };
        let m: Vec<f64> = [128, 512, 2048].iter().map(|&n| g.moments(n).0).collect();
        // brute: θ about the normal, in u = θ with fine steps near the mirror direction
        let (nt, np) = (20000, 2000);
        let mut s = 0.0;
        for i in 0..nt {
            let th = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
            for j in 0..np {
                let ph = (j as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
                let w = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                s += g.eval(w) * th.sin();
            }
        }
        s *= std::f64::consts::FRAC_PI_2 / nt as f64 * 2.0 * std::f64::consts::PI / np as f64;
        println!("alpha {alpha} ct {ct}: moments {m:?} brute {s}");
    }
}
