//! Instruction counts of the RBF map step and the farthest-point centres (docs/decisions/0003):
//! `rbfstep step|step-old|farthest|farthest-old [D]`, a 500-centre linear-kernel map of
//! dimension D (default 6) stepped 20,000 times, or 500 centres picked from 29,000 rows.
//! `*-old` runs the loops as they were before the one-pass versions (kept here), for
//! `valgrind --tool=callgrind` side by side. Prints a checksum of the result.

use faer::Mat;
use ssm::dynamics::{Kernel, RbfMap, farthest_points};
use ssm::ridge::Conditioning;
use ssm::testing::XorShift64;

fn step_old(m: &RbfMap, eta: &mut [f64], f: &mut [f64]) {
    let d = m.dim;
    let k = m.n_centers();
    let z: Vec<f64> = eta.iter().zip(&m.scale).map(|(e, s)| e / s).collect();
    for i in 0..k {
        let c = &m.centers[i * d..(i + 1) * d];
        let r = c.iter().zip(z.iter()).map(|(c, z)| (z - c).powi(2)).sum::<f64>().sqrt();
        f[i] = m.kernel.phi(r);
    }
    for j in 0..d {
        f[k + j] = eta[j] / m.scale[j];
    }
    f[k + d] = 1.0;
    for (r, fr) in f.iter().enumerate() {
        for j in 0..d {
            eta[j] += m.coef[r * d + j] * fr;
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map_or("step", String::as_str);
    let d: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(6);
    let mut rnd = XorShift64::new(9);
    let k = 500;
    match what {
        "step" | "step-old" => {
            let cond = Conditioning {
                rows: 0,
                cols: 0,
                s_max: 1.0,
                s_min: 1.0,
                cond: 1.0,
                alpha: 0.0,
                cond_regularized: 1.0,
                rel_residual: 0.0,
            };
            let coef: Vec<f64> = (0..(k + d + 1) * d)
                .map(|i| {
                    if i < k * d {
                        1e-4 * rnd.centered()
                    } else if i < (k + d) * d {
                        if (i - k * d) % (d + 1) == 0 { -0.01 } else { 0.0 }
                    } else {
                        0.0
                    }
                })
                .collect();
            let m = RbfMap {
                dim: d,
                kernel: Kernel::Linear,
                dt: 0.1,
                scale: vec![0.7; d],
                centers: (0..k * d).map(|_| rnd.centered()).collect(),
                coef,
                conditioning: cond,
            };
            let mut eta: Vec<f64> = (0..d).map(|_| 0.3 * rnd.centered()).collect();
            let mut feat = Vec::new();
            let mut f = vec![0.0; k + d + 1];
            for _ in 0..20_000 {
                if what == "step" {
                    m.step(&mut eta, &mut feat);
                } else {
                    step_old(&m, &mut eta, &mut f);
                }
            }
            println!("{:?}", eta.iter().map(|v| v.to_bits()).fold(0u64, |a, b| a.rotate_left(7) ^ b));
        }
        _ => {
            let n = 29_000;
            let z = Mat::from_fn(n, d, |i, j| ((i as f64) * 0.001 * (j + 1) as f64).sin() + 0.01 * rnd.centered());
            let c = if what == "farthest" { farthest_points(z.as_ref(), k) } else { farthest_old(&z, k) };
            println!("{}", c.iter().fold(0usize, |a, b| a.wrapping_mul(31).wrapping_add(*b)));
        }
    }
}

fn farthest_old(z: &Mat<f64>, k: usize) -> Vec<usize> {
    let n = z.nrows();
    let d = z.ncols();
    let rows: Vec<f64> = (0..n).flat_map(|i| (0..d).map(move |j| z[(i, j)])).collect();
    let row = |a: usize| &rows[a * d..(a + 1) * d];
    let dist2 = |a: usize, b: usize| row(a).iter().zip(row(b)).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
    let norm2 = |a: usize| row(a).iter().map(|x| x.powi(2)).sum::<f64>();
    let mut chosen = Vec::with_capacity(k.min(n));
    let first = (0..n).max_by(|&a, &b| norm2(a).total_cmp(&norm2(b))).unwrap_or(0);
    chosen.push(first);
    let mut mind: Vec<f64> = (0..n).map(|i| dist2(i, first)).collect();
    while chosen.len() < k.min(n) {
        let next = (0..n).max_by(|&a, &b| mind[a].total_cmp(&mind[b])).unwrap_or(0);
        if mind[next] == 0.0 {
            break;
        }
        chosen.push(next);
        let c = row(next);
        for (m, r) in mind.iter_mut().zip(rows.chunks_exact(d.max(1))) {
            *m = m.min(r.iter().zip(c).map(|(x, y)| (x - y).powi(2)).sum::<f64>());
        }
    }
    chosen
}
