use nalgebra::{SMatrix, SVector};
use sim::plant::linearize::*;
use sim::plant::{Cart, Furuta};
use sim::plant::{Plant, Scalar};

/// Central differences of `f` in `x_j` and in `u`, step `h` scaled per component.
fn fd_check<P: Plant<N>, const N: usize>(p: &P, x: &[f64; N], u: f64, rtol: f64) {
    let (f, jac) = jacobian(p, x, u);
    let f0 = p.rhs(x, u);
    assert_eq!(f, f0);
    for j in 0..N {
        let h = 1e-6 * x[j].abs().max(1.0);
        let mut xp = *x;
        let mut xm = *x;
        xp[j] += h;
        xm[j] -= h;
        let (fp, fm) = (p.rhs(&xp, u), p.rhs(&xm, u));
        for i in 0..N {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            let scale = jac[i].iter().fold(1.0f64, |a, v| a.max(v.abs()));
            assert!(
                (fd - jac[i][j]).abs() <= rtol * scale,
                "{} x={x:?} d f{i}/d x{j}: dual {} vs fd {fd}",
                p.name(),
                jac[i][j]
            );
        }
    }
    let bu = input_jacobian(p, x, u);
    let h = 1e-6 * u.abs().max(1.0);
    let (fp, fm) = (p.rhs(x, u + h), p.rhs(x, u - h));
    for i in 0..N {
        let fd = (fp[i] - fm[i]) / (2.0 * h);
        assert!((fd - bu[i]).abs() <= rtol * bu[i].abs().max(1.0), "d f{i}/du {} vs {fd}", bu[i]);
    }
}

#[test]
fn jacobian_matches_central_differences() {
    let f = Furuta::paper();
    let c = Cart::reference();
    for (x, u) in [([0.0, 0.0, 0.0, 0.0], 0.0), ([0.3, -1.2, 4.0, 2.5], 1.7), ([-2.0, 3.0, -1.0, -7.0], -12.0)] {
        fd_check(&f, &x, u, 1e-7);
        fd_check(&c, &x, u, 1e-7);
    }
}

#[test]
fn furuta_open_loop_eigenvalues() {
    let (a, b) = linearize(&Furuta::paper());
    let mut ev: Vec<f64> = a
        .complex_eigenvalues()
        .iter()
        .map(|z| {
            assert!(z.im.abs() < 1e-9 * z.re.abs().max(1.0), "complex eigenvalue {z}");
            z.re
        })
        .collect();
    ev.sort_by(f64::total_cmp);
    // MODEL.md: about -1.56e4, -11.1, 0, +4.39 1/s.
    let want = [-1.56e4, -11.1, 0.0, 4.39];
    let tol = [0.01e4, 0.1, 1e-9, 0.01];
    for i in 0..4 {
        assert!((ev[i] - want[i]).abs() <= tol[i], "eigenvalues {ev:?}");
    }
    // B: only the accelerations respond to the voltage, d(theta'')/du = mrl*N/Delta(0).
    let p = Furuta::paper();
    let q = p.params();
    let mrl = q.m * q.r * q.l;
    let d0 = p.delta(0.0);
    assert_eq!((b[0], b[2]), (0.0, 0.0));
    assert!((b[1] - mrl * q.n / d0).abs() < 1e-9 * b[1].abs());
    assert!((b[3] - q.jp * q.n / d0).abs() < 1e-9 * b[3].abs());
}

#[test]
fn jacobian_of_a_linear_plant_is_its_matrix() {
    struct Lin;
    impl Plant<2> for Lin {
        const PRIMARY: usize = 0;
        const SECONDARY: usize = 1;
        fn name(&self) -> &'static str {
            "lin"
        }
        fn state_names(&self) -> [&'static str; 2] {
            ["a", "b"]
        }
        fn rhs<S: Scalar>(&self, x: &[S; 2], u: S) -> [S; 2] {
            [x[0] * 2.0 - x[1] * 3.0 + u, x[0] * 0.5 + u * 7.0]
        }
        fn energy(&self, _: &[f64; 2]) -> f64 {
            0.0
        }
    }
    let (a, b) = linearize(&Lin);
    assert_eq!(a, SMatrix::<f64, 2, 2>::new(2.0, -3.0, 0.5, 0.0));
    assert_eq!(b, SVector::<f64, 2>::new(1.0, 7.0));
}
