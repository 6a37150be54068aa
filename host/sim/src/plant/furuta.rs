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

    /// `m r l`, kg m^2: the coupling of the two links in the mass matrix.
    pub fn mrl(&self) -> f64 {
        self.mrl
    }

    /// `m g l`, N m: the gravity torque on the pendulum at `sin(theta) = 1`.
    pub fn mgl(&self) -> f64 {
        self.mgl
    }

    /// `Jp*Ja - mrl^2`, kg^2 m^4: the minimum of `Delta` (at `theta = 0`).
    pub fn delta0(&self) -> f64 {
        self.delta0
    }

    /// `Jp^2 + mrl^2`, kg^2 m^4: `Delta = delta0 + delta_s2 * sin^2(theta)`.
    pub fn delta_s2(&self) -> f64 {
        self.delta_s2
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
