//! The rotary inverted (Furuta) pendulum of the paper, with the two printed typos corrected
//! (see `shared/MODEL.md`): state `(theta, w_theta, phi, w_phi)`, `theta` the pendulum angle
//! from upright, `phi` the arm angle, input `u` the motor voltage.
//!
//! The mass matrix is `[[Jp, -mrl c], [-mrl c, Ja + Jp s^2]]` with determinant
//! `Delta = Jp*(Ja + Jp*s^2) - mrl^2*c^2`. Using `c^2 = 1 - s^2` it is evaluated as
//! `(Jp*Ja - mrl^2) + (Jp^2 + mrl^2)*s^2`: the cancellation happens once, in the constant, and
//! the state-dependent part is a sum of non-negative terms.

use serde::{Deserialize, Serialize};

use super::{Plant, PlantError, Scalar, Sign, check_delta, check_fields};

/// Physical parameters, SI units. `Default` is the paper's table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FurutaParams {
    /// Pendulum mass, kg.
    pub m: f64,
    /// Distance from the pendulum pivot to its centre of mass, m.
    pub l: f64,
    /// Arm length (motor axis to pendulum pivot), m.
    pub r: f64,
    /// Gravitational acceleration, m/s^2.
    pub g: f64,
    /// Pendulum moment of inertia about its pivot, kg m^2.
    pub jp: f64,
    /// Arm moment of inertia about the motor axis, kg m^2.
    pub ja: f64,
    /// Viscous damping of the pendulum joint, N m s.
    pub b1: f64,
    /// Viscous damping of the arm joint, N m s.
    pub b2: f64,
    /// Motor torque per volt, N m / V.
    pub n: f64,
    /// Motor back-EMF damping, N m s.
    pub k: f64,
}

impl Default for FurutaParams {
    fn default() -> Self {
        Self {
            m: 0.191,
            l: 0.15,
            r: 0.094,
            g: 9.81,
            jp: 5.73e-3,
            ja: 1.34e-3,
            b1: 0.039,
            b2: 0.02094,
            n: 1.05,
            k: 1.12706,
        }
    }
}

/// A validated Furuta pendulum with its constants precomputed for a cheap right-hand side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Furuta {
    pub(crate) params: FurutaParams,
    pub(crate) mrl: f64,
    pub(crate) mgl: f64,
    pub(crate) two_jp: f64,
    /// `Jp*Ja - mrl^2`: the minimum of `Delta` (at `theta = 0`).
    pub(crate) delta0: f64,
    /// `Jp^2 + mrl^2`: `Delta = delta0 + delta_s2 * sin^2(theta)`.
    pub(crate) delta_s2: f64,
}

impl Furuta {
    /// Validates the parameters: all finite; masses, lengths, inertias, `g` and `N` positive;
    /// damping and `K` non-negative; `Delta(theta) > 0` for every `theta`, and its minimum
    /// `Jp*Ja - (m r l)^2` not below `1e-9 * Jp*Ja` (near-singular).
    pub fn new(params: FurutaParams) -> Result<Self, PlantError> {
        let p = params;
        check_fields(&[
            ("m", p.m, Sign::Positive),
            ("l", p.l, Sign::Positive),
            ("r", p.r, Sign::Positive),
            ("g", p.g, Sign::Positive),
            ("jp", p.jp, Sign::Positive),
            ("ja", p.ja, Sign::Positive),
            ("b1", p.b1, Sign::NonNegative),
            ("b2", p.b2, Sign::NonNegative),
            ("n", p.n, Sign::Positive),
            ("k", p.k, Sign::NonNegative),
        ])?;
        let mrl = p.m * p.r * p.l;
        let delta0 = p.jp * p.ja - mrl * mrl;
        check_delta(delta0, p.jp * p.ja, "Jp*Ja - (m*r*l)^2")?;
        Ok(Self { params, mrl, mgl: p.m * p.g * p.l, two_jp: 2.0 * p.jp, delta0, delta_s2: p.jp * p.jp + mrl * mrl })
    }

    /// The paper's plant.
    pub fn paper() -> Self {
        // The paper's parameters pass validation (Delta(0) = 4.25e-7 > 0).
        match Self::new(FurutaParams::default()) {
            Ok(p) => p,
            Err(e) => unreachable!("the paper's parameters are valid: {e}"),
        }
    }

    pub fn params(&self) -> &FurutaParams {
        &self.params
    }

    /// `Delta(theta)`, the determinant of the mass matrix, kg^2 m^4.
    pub fn delta(&self, theta: f64) -> f64 {
        let s = theta.sin();
        self.delta0 + self.delta_s2 * s * s
    }
}

impl Plant<4> for Furuta {
    const PRIMARY: usize = 0;
    const SECONDARY: usize = 2;

    fn name(&self) -> &'static str {
        "furuta"
    }

    fn state_names(&self) -> [&'static str; 4] {
        ["theta", "w_theta", "phi", "w_phi"]
    }

    #[inline]
    fn rhs<S: Scalar>(&self, x: &[S; 4], u: S) -> [S; 4] {
        let p = &self.params;
        // By reference (`Scalar::mul_ref` etc., the operators for f64): a truncated power
        // series is 5.7 kB. The by-value formula, which the tests hold this to bit for bit:
        //   s2 = s s, sc = s c, ja_eff = s2 Jp + Ja, delta = s2 delta_s2 + delta0,
        //   a = (u n - wp k) - sc wt wp 2Jp - wp b2 - s wt wt mrl,
        //   b = sc wp wp Jp - wt b1 + s mgl, inv = 1 / delta, mrl_c = c mrl,
        //   th_dd = (ja_eff b + mrl_c a) inv, ph_dd = (a Jp + mrl_c b) inv.
        let [th, wt, _phi, wp] = x;
        let (s, c) = th.sin_cos();
        let s2 = s.mul_ref(&s);
        let sc = s.mul_ref(&c);
        // Arm inertia seen by the motor, Ja + Jp*s^2.
        let ja_eff = s2.scaled(p.jp) + p.ja;
        let delta = s2.scaled(self.delta_s2) + self.delta0;
        let motor = u.scaled(p.n).sub_ref(&wp.scaled(p.k));
        let a = motor
            .sub_ref(&sc.mul_ref(wt).mul_ref(wp).scaled(self.two_jp))
            .sub_ref(&wp.scaled(p.b2))
            .sub_ref(&s.mul_ref(wt).mul_ref(wt).scaled(self.mrl));
        let b = sc.mul_ref(wp).mul_ref(wp).scaled(p.jp).sub_ref(&wt.scaled(p.b1)).add_ref(&s.scaled(self.mgl));
        let inv = S::cst(1.0) / delta;
        let mrl_c = c.scaled(self.mrl);
        let th_dd = ja_eff.mul_ref(&b).add_ref(&mrl_c.mul_ref(&a)).mul_ref(&inv);
        let ph_dd = a.scaled(p.jp).add_ref(&mrl_c.mul_ref(&b)).mul_ref(&inv);
        [*wt, th_dd, *wp, ph_dd]
    }

    /// The right-hand side and its Jacobian in closed form (about a third of the work of the
    /// dual-number evaluation). With `N1 = Ja_eff b + mrl c a`, `N2 = Jp a + mrl c b`:
    /// `d(N/Delta)/dq = (dN/dq - (N/Delta) dDelta/dq) / Delta` for `q` in `theta, w_theta,
    /// w_phi` (`phi` does not appear). Checked against the dual numbers in the tests.
    #[inline(always)]
    fn rhs_and_jacobian(&self, x: &[f64; 4], u: f64) -> ([f64; 4], [[f64; 4]; 4]) {
        let p = &self.params;
        let [th, wt, _phi, wp] = *x;
        let (s, c) = th.sin_cos();
        let s2 = s * s;
        let sc = s * c;
        // cos(2 theta) = c^2 - s^2: d(sc)/d theta.
        let c2 = c * c - s2;
        let ja_eff = s2 * p.jp + p.ja;
        let delta = s2 * self.delta_s2 + self.delta0;
        let motor = u * p.n - wp * p.k;
        let two_jp_sc = sc * self.two_jp;
        let mrl_s = s * self.mrl;
        let a = motor - two_jp_sc * wt * wp - wp * p.b2 - mrl_s * wt * wt;
        let b = sc * wp * wp * p.jp - wt * p.b1 + s * self.mgl;
        let inv = 1.0 / delta;
        let mrl_c = c * self.mrl;
        let th_dd = (ja_eff * b + mrl_c * a) * inv;
        let ph_dd = (a * p.jp + mrl_c * b) * inv;
        // Partial derivatives of a and b.
        let a_th = -(c2 * self.two_jp * wt * wp) - mrl_c * wt * wt;
        let a_wt = -(two_jp_sc * wp) - 2.0 * mrl_s * wt;
        let a_wp = -p.k - two_jp_sc * wt - p.b2;
        let b_th = c2 * p.jp * wp * wp + c * self.mgl;
        let b_wt = -p.b1;
        let b_wp = 2.0 * sc * p.jp * wp;
        // d Delta / d theta and d Ja_eff / d theta.
        let d_th = 2.0 * self.delta_s2 * sc;
        let n1_th = two_jp_sc * b + ja_eff * b_th - mrl_s * a + mrl_c * a_th;
        let n2_th = p.jp * a_th - mrl_s * b + mrl_c * b_th;
        let j1 = [
            (n1_th - th_dd * d_th) * inv,
            (ja_eff * b_wt + mrl_c * a_wt) * inv,
            0.0,
            (ja_eff * b_wp + mrl_c * a_wp) * inv,
        ];
        let j3 =
            [(n2_th - ph_dd * d_th) * inv, (p.jp * a_wt + mrl_c * b_wt) * inv, 0.0, (p.jp * a_wp + mrl_c * b_wp) * inv];
        ([wt, th_dd, wp, ph_dd], [[0.0, 1.0, 0.0, 0.0], j1, [0.0, 0.0, 0.0, 1.0], j3])
    }

    fn energy(&self, x: &[f64; 4]) -> f64 {
        let p = &self.params;
        let [th, wt, _phi, wp] = *x;
        let (s, c) = th.sin_cos();
        let t = 0.5 * p.jp * wt * wt + 0.5 * (p.ja + p.jp * s * s) * wp * wp - self.mrl * c * wt * wp;
        t + self.mgl * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The equations exactly as written in MODEL.md, with no rearrangement.
    fn model_md(p: &FurutaParams, x: &[f64; 4], u: f64) -> [f64; 4] {
        let [th, wt, _, wp] = *x;
        let (s, c) = (th.sin(), th.cos());
        let mrl = p.m * p.r * p.l;
        let delta = p.jp * (p.ja + p.jp * s * s) - mrl * mrl * c * c;
        let m = p.n * u - p.k * wp;
        let a = m - 2.0 * p.jp * s * c * wt * wp - p.b2 * wp - mrl * s * wt * wt;
        let b = p.jp * s * c * wp * wp - p.b1 * wt + p.m * p.g * p.l * s;
        [wt, ((p.ja + p.jp * s * s) * b + mrl * c * a) / delta, wp, (p.jp * a + mrl * c * b) / delta]
    }

    #[test]
    // 1.5707 is a state near (not at) pi/2 on purpose.
    #[allow(clippy::approx_constant)]
    fn rhs_matches_model_md() {
        let f = Furuta::paper();
        for (x, u) in [
            ([0.0, 0.0, 0.0, 0.0], 0.0),
            ([0.3, -1.2, 4.0, 2.5], 1.7),
            ([-2.9, 3.0, -1.0, -7.0], -12.0),
            ([1.5707, 0.1, 0.0, 30.0], 24.0),
        ] {
            let got = f.rhs(&x, u);
            let want = model_md(f.params(), &x, u);
            for i in 0..4 {
                // The reference loses about a digit to cancellation in Delta.
                let tol = 1e-12 * want[i].abs().max(1.0);
                assert!((got[i] - want[i]).abs() <= tol, "x={x:?} i={i}: {} vs {}", got[i], want[i]);
            }
        }
    }

    /// The closed-form Jacobian against the dual-number one at random states (a fixed-seed
    /// LCG), from the upright to tumbling: the same values to rounding.
    #[test]
    fn closed_form_jacobian_matches_dual_numbers() {
        let plant = Furuta::paper();
        let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
        let mut uniform = |lo: f64, hi: f64| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
        };
        let mut worst = 0.0f64;
        for k in 0..500 {
            // The first states near the upright, where the controller keeps the pendulum.
            let r = if k < 100 { 0.05 } else { 1.0 };
            let x = [uniform(-3.2, 3.2) * r, uniform(-20.0, 20.0) * r, uniform(-10.0, 10.0), uniform(-40.0, 40.0) * r];
            let u = uniform(-24.0, 24.0);
            let (f, jac) = plant.rhs_and_jacobian(&x, u);
            let (fd, jd) = crate::plant::jacobian(&plant, &x, u);
            for i in 0..4 {
                let scale = jd[i].iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
                for j in 0..4 {
                    let e = (jac[i][j] - jd[i][j]).abs() / scale;
                    worst = worst.max(e);
                    assert!(e <= 1e-12, "x={x:?} u={u}: d f{i}/d x{j} = {:e}, dual {:e}", jac[i][j], jd[i][j]);
                }
                assert!((f[i] - fd[i]).abs() <= 1e-14 * fd[i].abs().max(1.0), "x={x:?}: f{i} {} vs {}", f[i], fd[i]);
            }
        }
        eprintln!("closed-form vs dual Jacobian: worst relative difference {worst:e}");
    }

    #[test]
    fn energy_rate_equals_power_balance() {
        // dE/dt = N*u*w_phi - K*w_phi^2 - b1*w_theta^2 - b2*w_phi^2 along the flow.
        let f = Furuta::paper();
        let p = *f.params();
        let x = [0.4, -0.7, 0.2, 1.3];
        let u = 2.0;
        let dx = f.rhs(&x, u);
        let eps = 1e-6;
        let xp: [f64; 4] = core::array::from_fn(|i| x[i] + eps * dx[i]);
        let xm: [f64; 4] = core::array::from_fn(|i| x[i] - eps * dx[i]);
        let de = (f.energy(&xp) - f.energy(&xm)) / (2.0 * eps);
        let power = p.n * u * x[3] - p.k * x[3] * x[3] - p.b1 * x[1] * x[1] - p.b2 * x[3] * x[3];
        assert!((de - power).abs() < 1e-7 * power.abs().max(1.0), "{de} vs {power}");
    }

    #[test]
    fn paper_delta_min() {
        let f = Furuta::paper();
        let p = f.params();
        let want = p.jp * p.ja - (p.m * p.r * p.l).powi(2);
        assert!((f.delta(0.0) - want).abs() < 1e-20, "{} vs {want}", f.delta(0.0));
        // MODEL.md: Delta(0) = 4.25e-7.
        assert!((f.delta(0.0) - 4.25e-7).abs() < 0.01e-7, "{}", f.delta(0.0));
        // The general formula at theta = 1.
        let (s, c) = 1.0f64.sin_cos();
        let d1 = p.jp * (p.ja + p.jp * s * s) - (p.m * p.r * p.l * c).powi(2);
        assert!((f.delta(1.0) - d1).abs() < 1e-12 * d1);
        assert!(f.delta(1.0) > f.delta(0.0));
    }

    #[test]
    fn validation_names_the_field() {
        let base = FurutaParams::default();
        let cases: [(FurutaParams, PlantError); 6] = [
            (FurutaParams { jp: f64::NAN, ..base }, PlantError::NotFinite { field: "jp", value: f64::NAN }),
            (FurutaParams { k: f64::INFINITY, ..base }, PlantError::NotFinite { field: "k", value: f64::INFINITY }),
            (FurutaParams { m: 0.0, ..base }, PlantError::NotPositive { field: "m", value: 0.0 }),
            (FurutaParams { n: -1.0, ..base }, PlantError::NotPositive { field: "n", value: -1.0 }),
            (FurutaParams { b2: -0.1, ..base }, PlantError::Negative { field: "b2", value: -0.1 }),
            (FurutaParams { b1: -1e-9, ..base }, PlantError::Negative { field: "b1", value: -1e-9 }),
        ];
        for (p, want) in cases {
            let got = Furuta::new(p).unwrap_err();
            match (&got, &want) {
                (PlantError::NotFinite { field: a, .. }, PlantError::NotFinite { field: b, .. }) => {
                    assert_eq!(a, b)
                }
                _ => assert_eq!(got, want),
            }
            let field = match want {
                PlantError::NotFinite { field, .. }
                | PlantError::NotPositive { field, .. }
                | PlantError::Negative { field, .. } => field,
                _ => unreachable!(),
            };
            assert!(got.to_string().contains(&format!("`{field}`")), "{got}");
        }
        // Zero damping and zero back-EMF are allowed.
        assert!(Furuta::new(FurutaParams { b1: 0.0, b2: 0.0, k: 0.0, ..base }).is_ok());
    }

    #[test]
    fn singular_and_near_singular_mass_matrix_rejected() {
        let base = FurutaParams::default();
        let mrl = base.m * base.r * base.l;
        // Delta(0) exactly zero or negative: ja = mrl^2/jp, or smaller.
        for ja in [mrl * mrl / base.jp * 0.999, mrl * mrl / base.jp * 0.5] {
            match Furuta::new(FurutaParams { ja, ..base }) {
                Err(PlantError::SingularMassMatrix { delta_min, .. }) => assert!(delta_min <= 0.0),
                other => panic!("ja={ja}: {other:?}"),
            }
        }
        // Positive but tiny: 1e-11 relative.
        let ja = mrl * mrl / base.jp * (1.0 + 1e-11);
        match Furuta::new(FurutaParams { ja, ..base }) {
            Err(PlantError::NearSingularMassMatrix { delta_min, threshold, .. }) => {
                assert!(delta_min > 0.0 && delta_min < threshold, "{delta_min} {threshold}");
                assert!(delta_min.is_finite());
            }
            other => panic!("{other:?}"),
        }
        // Comfortably positive: accepted, and the rhs is finite at the worst angle.
        let ja = mrl * mrl / base.jp * (1.0 + 1e-6);
        let f = Furuta::new(FurutaParams { ja, ..base }).unwrap();
        assert!(f.rhs(&[0.0, 1.0, 0.0, 1.0], 1.0).iter().all(|v| v.is_finite()));
    }

    #[test]
    fn params_serde_defaults_and_unknown_fields() {
        let p: FurutaParams = serde_json::from_str(r#"{"m": 0.2}"#).unwrap();
        assert_eq!(p, FurutaParams { m: 0.2, ..FurutaParams::default() });
        let e = serde_json::from_str::<FurutaParams>(r#"{"mass": 0.2}"#).unwrap_err();
        assert!(e.to_string().contains("mass"), "{e}");
    }
}
