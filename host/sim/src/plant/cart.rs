//! A planar inverted pendulum on a cart, the cart pulled by a belt over a pulley on a DC motor:
//! state `(theta, w_theta, x, v)`, `theta` the pendulum angle from upright, `x` the cart
//! position, input `u` the motor voltage.
//!
//! Geometry and sign conventions are chosen so that the Furuta controller applies unchanged:
//! the pendulum's centre of mass is at `(x - l sin(theta), l cos(theta))` (positive `theta`
//! leans towards `-x`), so a positive voltage accelerates the cart towards `+x` and tips the
//! pendulum towards positive `theta`, as the arm does in the Furuta pendulum.
//!
//! Lagrangian with `Jp` the pendulum inertia about its pivot and `M = mc + m`:
//! `T = M v^2/2 - m l cos(theta) v w + Jp w^2/2`, `V = m g l cos(theta)`, giving
//!
//! ```text
//!     [  Jp     -m l c ] [w']   [ m g l s - bp w               ]
//!     [ -m l c   M     ] [v'] = [ F - bc v - m l s w^2          ]
//! ```
//!
//! The motor (torque per volt `n`, back-EMF damping `k`, as in the Furuta model) drives the
//! belt through a pulley of radius `rho`: the motor torque is `n u - k w_motor` with
//! `w_motor = v / rho`, and the force on the cart is that torque over `rho`:
//! `F = (n u - k v / rho) / rho`. The mass-matrix determinant
//! `Delta = Jp M - (m l c)^2 >= Jp M - (m l)^2` is smallest at `theta = 0`.

use serde::{Deserialize, Serialize};

use super::{Plant, PlantError, Scalar, Sign, check_delta, check_fields};

/// Physical parameters, SI units. `Default` is a bench-top cart (see [`Cart::reference`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CartParams {
    /// Cart mass (with the belt and the pulley's reflected inertia), kg.
    pub mc: f64,
    /// Pendulum mass, kg.
    pub m: f64,
    /// Distance from the pivot to the pendulum's centre of mass, m.
    pub l: f64,
    /// Pendulum moment of inertia about its pivot, kg m^2 (at least `m l^2`).
    pub jp: f64,
    /// Gravitational acceleration, m/s^2.
    pub g: f64,
    /// Viscous damping of the pendulum joint, N m s.
    pub bp: f64,
    /// Viscous friction of the cart, N s/m.
    pub bc: f64,
    /// Pulley radius, m.
    pub rho: f64,
    /// Motor torque per volt, N m / V.
    pub n: f64,
    /// Motor back-EMF damping, N m s.
    pub k: f64,
}

impl Default for CartParams {
    fn default() -> Self {
        // Of the order of a commercial teaching rig: a 0.94 kg cart driven through a
        // 6.35 mm pinion by a geared DC motor (effective torque constant 0.0285 N m/A,
        // winding 2.6 ohm: n = Kt/R, k = Kt^2/R, i.e. 1.73 N per volt at standstill and
        // 7.7 N s/m electrical damping), and a 0.23 kg uniform rod with its centre of mass
        // 0.33 m above the pivot.
        let (m, l) = (0.23, 0.33);
        Self {
            mc: 0.94,
            m,
            l,
            jp: 4.0 / 3.0 * m * l * l,
            g: 9.81,
            bp: 2.4e-3,
            bc: 4.3,
            rho: 6.35e-3,
            n: 0.011,
            k: 3.1e-4,
        }
    }
}

/// A validated cart-pendulum with its constants precomputed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cart {
    params: CartParams,
    mt: f64,
    ml: f64,
    mgl: f64,
    /// Force per volt, `n / rho`, N/V.
    fu: f64,
    /// Total velocity damping of the cart, `bc + k / rho^2`, N s/m.
    fv: f64,
    /// `Jp*M - (m l)^2`: the minimum of `Delta`.
    delta0: f64,
    /// `(m l)^2`: `Delta = delta0 + (m l)^2 sin^2(theta)`.
    delta_s2: f64,
}

impl Cart {
    /// Validates the parameters: all finite; masses, lengths, inertia, `g`, `rho`, `n`
    /// positive; damping and `k` non-negative; `Delta` bounded away from zero (minimum
    /// `Jp*(mc+m) - (m l)^2` at least `1e-9 * Jp*(mc+m)`).
    pub fn new(params: CartParams) -> Result<Self, PlantError> {
        let p = params;
        check_fields(&[
            ("mc", p.mc, Sign::Positive),
            ("m", p.m, Sign::Positive),
            ("l", p.l, Sign::Positive),
            ("jp", p.jp, Sign::Positive),
            ("g", p.g, Sign::Positive),
            ("bp", p.bp, Sign::NonNegative),
            ("bc", p.bc, Sign::NonNegative),
            ("rho", p.rho, Sign::Positive),
            ("n", p.n, Sign::Positive),
            ("k", p.k, Sign::NonNegative),
        ])?;
        let mt = p.mc + p.m;
        let ml = p.m * p.l;
        let delta0 = p.jp * mt - ml * ml;
        check_delta(delta0, p.jp * mt, "Jp*(mc+m) - (m*l)^2")?;
        Ok(Self {
            params,
            mt,
            ml,
            mgl: ml * p.g,
            fu: p.n / p.rho,
            fv: p.bc + p.k / (p.rho * p.rho),
            delta0,
            delta_s2: ml * ml,
        })
    }

    /// The default parameter set (valid by construction).
    pub fn reference() -> Self {
        match Self::new(CartParams::default()) {
            Ok(c) => c,
            Err(e) => unreachable!("the default cart parameters are valid: {e}"),
        }
    }

    pub fn params(&self) -> &CartParams {
        &self.params
    }

    /// `Delta(theta)`, the determinant of the mass matrix, kg^2 m^2.
    pub fn delta(&self, theta: f64) -> f64 {
        let s = theta.sin();
        self.delta0 + self.delta_s2 * s * s
    }
}

impl Plant<4> for Cart {
    const PRIMARY: usize = 0;
    const SECONDARY: usize = 2;

    fn name(&self) -> &'static str {
        "cart"
    }

    fn state_names(&self) -> [&'static str; 4] {
        ["theta", "w_theta", "x", "v"]
    }

    #[inline]
    fn rhs<S: Scalar>(&self, x: &[S; 4], u: S) -> [S; 4] {
        let p = &self.params;
        let [th, w, _x, v] = *x;
        let (s, c) = th.sin_cos();
        let delta = s * s * self.delta_s2 + self.delta0;
        let force = u * self.fu - v * self.fv;
        let r_th = s * self.mgl - w * p.bp;
        let r_x = force - s * w * w * self.ml;
        let inv = S::cst(1.0) / delta;
        let ml_c = c * self.ml;
        let w_dot = (r_th * self.mt + ml_c * r_x) * inv;
        let v_dot = (r_x * p.jp + ml_c * r_th) * inv;
        [w, w_dot, v, v_dot]
    }

    fn energy(&self, x: &[f64; 4]) -> f64 {
        let [th, w, _x, v] = *x;
        let c = th.cos();
        0.5 * self.mt * v * v - self.ml * c * v * w + 0.5 * self.params.jp * w * w + self.mgl * c
    }
}
