//! The on-device RBF predictor of an SSM-reduced model (`shared::model`).
//!
//! Owns the sample history (a fixed-capacity ring buffer), the projection to reduced
//! coordinates, the RBF map and the lift back to the observable. Never allocates, never
//! panics: capacities are const generics and running out of one is a [`LoadError`].
//! It does not decode blobs itself (that is `shared::model::Model::decode_into`).
//!
//! Conventions (see `shared::model`): the embedding is `y_j = s(t + j*shift*dt)`, so with
//! the window full, `y_{p-1}` is the newest sample pushed and `y_0` the oldest the model
//! uses; `eta = V1^T (y - offset) / scale`; one [`Predictor::step`] advances `t` by one sample
//! period; [`Predictor::lift`] returns component 0 of `M(eta) * scale + offset`, i.e.
//! `s(t)` for the window's reference time `t`.
//!
//! Operation order is fixed and documented at each function, so the host and the device
//! produce identical `f32` bits when they use the same [`SqrtFlavour`] (`Libm` and
//! `Hardware` are both correctly rounded, hence identical too).

use shared::model::{DecodeError, Model, monomial};

/// How the Euclidean norm's square root is computed in the RBF map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SqrtFlavour {
    /// `libm::sqrtf`: correctly rounded, in software (the costliest of the three on the M4F;
    /// the device table counts each).
    Libm,
    /// micromath's bit-trick approximation: cheap, not correctly rounded (a few percent off).
    Fast,
    /// The FPU's `vsqrt.f32` on Arm hard-float targets (correctly rounded, one instruction);
    /// `libm::sqrtf` elsewhere (bit-identical results).
    Hardware,
}

impl SqrtFlavour {
    /// The flavour used unless one is chosen: hardware on hard-float Arm, else libm.
    pub const DEFAULT: Self =
        if cfg!(all(target_arch = "arm", target_abi = "eabihf")) { Self::Hardware } else { Self::Libm };

    /// All flavours, for tests that cover each.
    pub const ALL: [Self; 3] = [Self::Libm, Self::Fast, Self::Hardware];

    /// Square root of `x` (`x >= 0` in the RBF map).
    #[inline]
    pub fn sqrt(self, x: f32) -> f32 {
        match self {
            Self::Libm => libm::sqrtf(x),
            Self::Fast => micromath::F32(x).sqrt().0,
            Self::Hardware => hw_sqrt(x),
        }
    }
}

impl Default for SqrtFlavour {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.ssm_vsqrt_f32,\"ax\",%progbits",
    ".global ssm_vsqrt_f32",
    ".type ssm_vsqrt_f32,%function",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    "ssm_vsqrt_f32:",
    "    vsqrt.f32 s0, s0",
    "    bx lr",
    ".size ssm_vsqrt_f32, . - ssm_vsqrt_f32",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
unsafe extern "C" {
    /// `s0 <- sqrt(s0)`; hard-float ABI passes and returns the f32 in `s0`.
    fn ssm_vsqrt_f32(x: f32) -> f32;
}

#[inline]
fn hw_sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: the function reads s0, writes s0 and returns; it touches no memory.
        unsafe { ssm_vsqrt_f32(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Why a model could not be loaded into a predictor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadError {
    /// The blob was rejected (or a dimension exceeds `P`, `D`, `K`, `T`).
    Decode(DecodeError),
    /// The window `(p-1)*shift + 1` samples does not fit the history capacity `H`.
    HistoryCapacity { needed: usize, max: usize },
}

impl From<DecodeError> for LoadError {
    fn from(e: DecodeError) -> Self {
        Self::Decode(e)
    }
}

impl core::fmt::Display for LoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Decode(e) => write!(f, "model rejected: {e}"),
            Self::HistoryCapacity { needed, max } => {
                write!(f, "delay window needs {needed} samples, history capacity is {max}")
            }
        }
    }
}

/// Why a prediction could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PredictError {
    /// Fewer samples than the delay window have been pushed since the last reset.
    NotReady { have: usize, need: usize },
    /// A pushed sample was NaN or infinite (it was not stored).
    NonFiniteSample,
    /// No model is loaded.
    NoModel,
}

/// An RBF predictor with capacities `P` (embedding dim), `D` (reduced dim), `K` (centres),
/// `T` (lift monomials) and `H` (history samples, at least `(p-1)*shift + 1`).
#[derive(Clone, Debug)]
pub struct Predictor<const P: usize, const D: usize, const K: usize, const T: usize, const H: usize> {
    model: Model<P, D, K, T>,
    loaded: bool,
    sqrt: SqrtFlavour,
    history: [f32; H],
    /// Index where the next sample goes.
    head: usize,
    /// Samples pushed since reset, saturating at `H`.
    filled: usize,
    /// `(p-1)*shift + 1` of the loaded model.
    window: usize,
}

impl<const P: usize, const D: usize, const K: usize, const T: usize, const H: usize> Predictor<P, D, K, T, H> {
    /// A predictor without a model, for a `static`; [`Self::load`] one before use.
    pub const fn empty(sqrt: SqrtFlavour) -> Self {
        Self { model: Model::empty(), loaded: false, sqrt, history: [0.0; H], head: 0, filled: 0, window: 0 }
    }

    /// Decodes `blob` into this predictor in place (no large stack temporaries) and clears
    /// the history. On a decode error the previous model stays loaded and the history is
    /// kept; on [`LoadError::HistoryCapacity`] the predictor is left without a model.
    pub fn load(&mut self, blob: &[u8]) -> Result<(), LoadError> {
        self.model.decode_into(blob)?;
        match self.check_window() {
            Ok(window) => {
                self.window = window;
                self.loaded = true;
                self.reset();
                Ok(())
            }
            Err(e) => {
                self.loaded = false;
                self.window = 0;
                self.reset();
                Err(e)
            }
        }
    }

    /// Builds a predictor owning `model` (host convenience).
    pub fn from_model(model: Model<P, D, K, T>, sqrt: SqrtFlavour) -> Result<Self, LoadError> {
        let mut s = Self::empty(sqrt);
        s.model = model;
        s.window = s.check_window()?;
        s.loaded = true;
        Ok(s)
    }

    fn check_window(&self) -> Result<usize, LoadError> {
        let m = &self.model;
        let needed = m
            .p()
            .checked_sub(1)
            .and_then(|n| n.checked_mul(m.shift()))
            .and_then(|n| n.checked_add(1))
            .unwrap_or(usize::MAX);
        if needed > H {
            return Err(LoadError::HistoryCapacity { needed, max: H });
        }
        Ok(needed)
    }

    pub fn model(&self) -> &Model<P, D, K, T> {
        &self.model
    }
    pub fn sqrt_flavour(&self) -> SqrtFlavour {
        self.sqrt
    }
    pub fn set_sqrt_flavour(&mut self, sqrt: SqrtFlavour) {
        self.sqrt = sqrt;
    }
    /// Samples the delay window spans, `(p-1)*shift + 1`.
    pub fn window_len(&self) -> usize {
        self.window
    }
    /// Whether a full window has been pushed since the last reset.
    pub fn is_ready(&self) -> bool {
        self.loaded && self.filled >= self.window
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.history = [0.0; H];
        self.head = 0;
        self.filled = 0;
    }

    /// Appends one sample of the observable (non-finite samples are refused, not stored).
    pub fn push(&mut self, sample: f32) -> Result<(), PredictError> {
        if !sample.is_finite() {
            return Err(PredictError::NonFiniteSample);
        }
        if let Some(slot) = self.history.get_mut(self.head) {
            *slot = sample;
        }
        self.head = match self.head.checked_add(1) {
            Some(n) if n < H => n,
            _ => 0,
        };
        self.filled = self.filled.saturating_add(1).min(H);
        Ok(())
    }

    /// The sample pushed `age` pushes ago (0 = newest).
    fn sample_ago(&self, age: usize) -> f32 {
        // head - 1 - age modulo H, without overflow: age < filled <= H.
        let back = age.checked_add(1).filter(|&a| a <= H);
        let idx = match back {
            Some(b) if b <= self.head => self.head - b,
            Some(b) => H - (b - self.head),
            None => 0,
        };
        self.history.get(idx).copied().unwrap_or(0.0)
    }

    fn ready(&self) -> Result<(), PredictError> {
        if !self.loaded {
            return Err(PredictError::NoModel);
        }
        if self.filled < self.window {
            return Err(PredictError::NotReady { have: self.filled, need: self.window });
        }
        Ok(())
    }

    /// The raw delay-embedding vector `y` (first `p` entries of the result).
    pub fn embedding(&self) -> Result<[f32; P], PredictError> {
        self.ready()?;
        let m = &self.model;
        let mut y = [0.0f32; P];
        let last = self.window.saturating_sub(1);
        for (j, yj) in y.iter_mut().take(m.p()).enumerate() {
            // y_j = s(t + j*shift): pushed (window-1 - j*shift) pushes ago.
            let age = last.saturating_sub(j.saturating_mul(m.shift()));
            *yj = self.sample_ago(age);
        }
        Ok(y)
    }

    /// Reduced coordinates of the current window:
    /// `z_i = (y_i - offset) / scale`, `eta_j = sum_i V1[i][j] z_i` (summed in `i` order).
    pub fn reduce(&self) -> Result<[f32; D], PredictError> {
        let y = self.embedding()?;
        Ok(self.project(&y))
    }

    /// `V1^T (y - offset) / scale` for an embedding vector `y` (first `p` entries used).
    pub fn project(&self, y: &[f32; P]) -> [f32; D] {
        let m = &self.model;
        let mut eta = [0.0f32; D];
        for (row, &yi) in m.v1().iter().zip(y.iter()) {
            let z = (yi - m.offset()) / m.scale();
            for (e, &v) in eta.iter_mut().zip(row.iter()).take(m.d()) {
                *e += v * z;
            }
        }
        eta
    }

    /// One step of the RBF map, in this order: `out_j = b_j`, then `out_j += A[j][l] eta_l`
    /// for `l = 0..d`, then for each centre `i`: `r_i = sqrt(sum_l (eta_l - c_il)^2)` and
    /// `out_j += w_ij r_i`.
    ///
    /// The loops run over the full capacity `D` (a fixed trip count the compiler unrolls,
    /// keeping `out` in registers): the model's entries at and beyond `d` are zero and `eta`'s
    /// are zeroed here, so every extra term is an exact `+0` and the result is the same as
    /// summing over `l < d` only. Entries `out_j`, `j >= d`, are zero (NaN if `r_i` overflows).
    pub fn step(&self, eta: &[f32; D]) -> [f32; D] {
        // One monomorphized loop per flavour: no dispatch per centre, the sqrt inlines.
        match self.sqrt {
            SqrtFlavour::Libm => self.step_with(eta, libm::sqrtf),
            SqrtFlavour::Fast => self.step_with(eta, |x| micromath::F32(x).sqrt().0),
            SqrtFlavour::Hardware => self.step_with(eta, hw_sqrt),
        }
    }

    #[inline(always)]
    fn step_with(&self, eta: &[f32; D], sqrt: impl Fn(f32) -> f32) -> [f32; D] {
        let m = &self.model;
        let mut e = [0.0f32; D];
        for (dst, &src) in e.iter_mut().zip(eta.iter()).take(m.d()) {
            *dst = src;
        }
        let mut out = [0.0f32; D];
        for ((o, row), &b) in out.iter_mut().zip(m.affine_linear()).zip(m.affine_bias()) {
            let mut acc = b;
            for (&a, &x) in row.iter().zip(e.iter()) {
                acc += a * x;
            }
            *o = acc;
        }
        for (c, w) in m.centres().iter().zip(m.weights()) {
            let mut r2 = 0.0f32;
            for (&x, &ci) in e.iter().zip(c.iter()) {
                let diff = x - ci;
                r2 += diff * diff;
            }
            let r = sqrt(r2);
            for (o, &wi) in out.iter_mut().zip(w.iter()) {
                *o += wi * r;
            }
        }
        out
    }

    /// `n` steps of the RBF map (`n = 0` returns `eta`).
    pub fn advance(&self, eta: &[f32; D], n: u32) -> [f32; D] {
        let mut e = *eta;
        for _ in 0..n {
            e = self.step(&e);
        }
        e
    }

    /// Component `i` of the lifted embedding, unnormalized:
    /// `(sum_j V1[i][j] eta_j + sum_t L[i][t] m_t(eta)) * scale + offset`, sums in index order.
    /// `None` if `i >= p`.
    pub fn lift_component(&self, eta: &[f32; D], i: usize) -> Option<f32> {
        let m = &self.model;
        let d = m.d();
        let mut mono = [0.0f32; T];
        let n = monomial::eval_into(eta.get(..d)?, m.lift_order(), &mut mono)?;
        let v = m.v1().get(i)?;
        let l = m.lift().get(i)?;
        let mut acc = 0.0f32;
        for (&a, &e) in v.iter().zip(eta.iter()).take(d) {
            acc += a * e;
        }
        for (&a, &x) in l.iter().zip(mono.iter()).take(n) {
            acc += a * x;
        }
        Some(acc * m.scale() + m.offset())
    }

    /// The observable at the reduced state `eta`: component 0 of the lift (`s(t)`).
    /// NaN only if no model is loaded.
    pub fn lift(&self, eta: &[f32; D]) -> f32 {
        self.lift_component(eta, 0).unwrap_or(f32::NAN)
    }

    /// Predicts the observable `n` sample periods after the window's reference time:
    /// `lift(advance(reduce(), n))`.
    pub fn predict(&self, n: u32) -> Result<f32, PredictError> {
        let eta = self.reduce()?;
        Ok(self.lift(&self.advance(&eta, n)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::ControllerConfig;
    use shared::model::ModelRef;

    // p = 5, shift = 2 (window 9), d = 2, lift order 3 (7 terms), k = 4.
    const V1: [f32; 10] = [0.45, 0.1, 0.44, -0.3, 0.43, -0.55, 0.42, 0.5, 0.41, 0.3];
    const LIFT: [f32; 35] = [
        0.05, -0.03, 0.02, 0.01, -0.015, 0.007, -0.004, //
        0.04, 0.03, -0.02, 0.01, 0.015, -0.007, 0.004, //
        -0.05, 0.02, 0.03, -0.01, 0.005, 0.006, 0.003, //
        0.01, -0.01, 0.01, -0.01, 0.01, -0.01, 0.01, //
        0.02, 0.02, -0.02, 0.03, -0.03, 0.001, 0.002,
    ];
    const CENTRES: [f32; 8] = [0.0, 0.0, 0.6, -0.4, -0.5, 0.5, 0.3, 0.9];
    const WEIGHTS: [f32; 8] = [0.02, -0.01, -0.015, 0.025, 0.01, 0.01, -0.02, 0.005];
    const AFFINE: [f32; 6] = [0.93, -0.25, 0.004, 0.25, 0.93, -0.003];

    fn model_ref() -> ModelRef<'static> {
        ModelRef {
            config: ControllerConfig::paper(0.002),
            p: 5,
            shift: 2,
            sample_period: 0.002,
            offset: 0.05,
            scale: 0.4,
            d: 2,
            lift_order: 3,
            k: 4,
            v1: &V1,
            lift: &LIFT,
            centres: &CENTRES,
            weights: &WEIGHTS,
            affine: &AFFINE,
        }
    }

    fn blob(m: &ModelRef<'_>) -> ([u8; 1024], usize) {
        let mut buf = [0u8; 1024];
        let n = m.encode_into(&mut buf).unwrap();
        (buf, n)
    }

    type Pred = Predictor<8, 4, 8, 16, 16>;

    fn loaded(sqrt: SqrtFlavour) -> Pred {
        let (buf, n) = blob(&model_ref());
        let mut p = Pred::empty(sqrt);
        p.load(&buf[..n]).unwrap();
        p
    }

    fn samples(n: usize) -> Vec<f32> {
        (0..n).map(|i| 0.3 * (0.21 * i as f32).sin() + 0.1 * (0.05 * i as f32).cos()).collect()
    }

    /// Independent f64 evaluation of the model formula (shared::model docs), written from
    /// the definitions: exponent vectors enumerated directly, no shared code.
    mod reference {
        use super::*;

        pub fn exponents(d: usize, order: usize) -> Vec<Vec<u32>> {
            fn rec(d: usize, left: u32, prefix: &mut Vec<u32>, out: &mut Vec<Vec<u32>>) {
                if prefix.len() == d - 1 {
                    prefix.push(left);
                    out.push(prefix.clone());
                    prefix.pop();
                    return;
                }
                for e in (0..=left).rev() {
                    prefix.push(e);
                    rec(d, left - e, prefix, out);
                    prefix.pop();
                }
            }
            let mut out = Vec::new();
            for deg in 2..=order as u32 {
                rec(d, deg, &mut Vec::new(), &mut out);
            }
            out
        }

        pub fn reduce(window: &[f64]) -> Vec<f64> {
            let m = model_ref();
            let y: Vec<f64> = (0..m.p).map(|j| window[j * m.shift]).collect();
            (0..m.d)
                .map(|j| (0..m.p).map(|i| V1[i * m.d + j] as f64 * (y[i] - m.offset as f64) / m.scale as f64).sum())
                .collect()
        }

        pub fn step(eta: &[f64]) -> Vec<f64> {
            let m = model_ref();
            let d = m.d;
            (0..d)
                .map(|j| {
                    let affine: f64 = (0..d).map(|l| AFFINE[j * (d + 1) + l] as f64 * eta[l]).sum::<f64>()
                        + AFFINE[j * (d + 1) + d] as f64;
                    let rbf: f64 = (0..m.k)
                        .map(|i| {
                            let r = (0..d).map(|l| (eta[l] - CENTRES[i * d + l] as f64).powi(2)).sum::<f64>().sqrt();
                            WEIGHTS[i * d + j] as f64 * r
                        })
                        .sum();
                    affine + rbf
                })
                .collect()
        }

        pub fn lift0(eta: &[f64]) -> f64 {
            let m = model_ref();
            let lin: f64 = (0..m.d).map(|j| V1[j] as f64 * eta[j]).sum();
            let exps = exponents(m.d, m.lift_order);
            let n = exps.len();
            let nl: f64 = exps
                .iter()
                .enumerate()
                .map(|(t, e)| LIFT[t] as f64 * e.iter().zip(eta).map(|(&k, &x)| x.powi(k as i32)).product::<f64>())
                .sum();
            assert_eq!(n, 7);
            (lin + nl) * m.scale as f64 + m.offset as f64
        }
    }

    #[test]
    fn predictions_match_f64_reference() {
        let s = samples(40);
        let mut worst = 0.0f64;
        for sqrt in [SqrtFlavour::Libm, SqrtFlavour::Hardware] {
            let mut p = loaded(sqrt);
            for &x in &s {
                p.push(x).unwrap();
            }
            let window: Vec<f64> = s[s.len() - 9..].iter().map(|&x| x as f64).collect();
            let mut eta = reference::reduce(&window);
            let got_eta = p.reduce().unwrap();
            for j in 0..2 {
                assert!((got_eta[j] as f64 - eta[j]).abs() <= 1e-6 * (1.0 + eta[j].abs()));
            }
            for n in 0..=30u32 {
                let want = reference::lift0(&eta);
                let got = p.predict(n).unwrap() as f64;
                // f32 evaluation of an O(1) formula over <= 30 steps of a contraction:
                // relative error bound 2e-5 (f32 epsilon 1.2e-7 times a generous growth factor).
                let tol = 2e-5 * want.abs().max(0.1);
                assert!((got - want).abs() <= tol, "{sqrt:?} n={n}: {got} vs {want}");
                worst = worst.max((got - want).abs() / want.abs().max(0.1));
                eta = reference::step(&eta);
            }
        }
        println!("worst relative error vs f64: {worst:.2e}");
        assert!(worst > 0.0, "f32 and f64 should differ somewhere (the comparison is live)");
    }

    #[test]
    fn fast_sqrt_error_is_bounded_by_its_five_percent() {
        let exact = loaded(SqrtFlavour::Libm);
        let fast = loaded(SqrtFlavour::Fast);
        for eta in [[0.1f32, -0.2, 0.0, 0.0], [1.0, 0.5, 0.0, 0.0], [-0.7, 0.9, 0.0, 0.0]] {
            let a = exact.step(&eta);
            let b = fast.step(&eta);
            // |error| <= 5 % of sum_i |w_ij| r_i.
            for j in 0..2 {
                let bound: f32 = (0..4)
                    .map(|i| {
                        let r = ((eta[0] - CENTRES[2 * i]).powi(2) + (eta[1] - CENTRES[2 * i + 1]).powi(2)).sqrt();
                        WEIGHTS[2 * i + j].abs() * r
                    })
                    .sum::<f32>()
                    * 0.05
                    + 1e-6;
                assert!((a[j] - b[j]).abs() <= bound, "{a:?} vs {b:?}");
            }
            assert_ne!(a, b, "the fast flavour is a different approximation");
        }
    }

    #[test]
    fn hardware_flavour_is_bit_identical_to_libm_here() {
        let a = loaded(SqrtFlavour::Libm);
        let b = loaded(SqrtFlavour::Hardware);
        let eta = [0.3f32, -0.8, 0.0, 0.0];
        assert_eq!(a.advance(&eta, 50).map(f32::to_bits), b.advance(&eta, 50).map(f32::to_bits));
    }

    #[test]
    fn n_steps_equal_repeated_single_steps() {
        for sqrt in SqrtFlavour::ALL {
            let p = loaded(sqrt);
            let start = [0.4f32, 0.2, 0.0, 0.0];
            let mut e = start;
            for n in 0..25u32 {
                assert_eq!(p.advance(&start, n).map(f32::to_bits), e.map(f32::to_bits), "{sqrt:?} n={n}");
                e = p.step(&e);
            }
        }
    }

    #[test]
    fn history_wraps_and_embedding_uses_shift() {
        let mut p = loaded(SqrtFlavour::Libm);
        let s = samples(53); // > 3 * H: the ring wraps several times
        for (i, &x) in s.iter().enumerate() {
            p.push(x).unwrap();
            if i + 1 >= 9 {
                let y = p.embedding().unwrap();
                let want: Vec<f32> = (0..5).map(|j| s[i + 1 - 9 + 2 * j]).collect();
                assert_eq!(&y[..5], &want[..], "after {} samples", i + 1);
            }
        }
    }

    #[test]
    fn not_ready_and_bad_samples_are_errors() {
        let mut p = loaded(SqrtFlavour::Libm);
        assert_eq!(p.predict(1), Err(PredictError::NotReady { have: 0, need: 9 }));
        for x in samples(8) {
            p.push(x).unwrap();
        }
        assert_eq!(p.predict(1), Err(PredictError::NotReady { have: 8, need: 9 }));
        assert_eq!(p.push(f32::NAN), Err(PredictError::NonFiniteSample));
        assert_eq!(p.push(f32::INFINITY), Err(PredictError::NonFiniteSample));
        p.push(0.0).unwrap();
        assert!(p.predict(1).is_ok());
        p.reset();
        assert!(!p.is_ready());
        let empty = Pred::empty(SqrtFlavour::Libm);
        assert_eq!(empty.predict(0), Err(PredictError::NoModel));
    }

    #[test]
    fn capacity_errors() {
        use shared::model::DecodeError::Capacity;
        let (buf, n) = blob(&model_ref());
        let blob = &buf[..n];
        let mut small_p = Predictor::<4, 4, 8, 16, 16>::empty(SqrtFlavour::Libm);
        assert_eq!(small_p.load(blob), Err(LoadError::Decode(Capacity { what: "p", max: 4, got: 5 })));
        let mut small_d = Predictor::<8, 1, 8, 16, 16>::empty(SqrtFlavour::Libm);
        assert_eq!(small_d.load(blob), Err(LoadError::Decode(Capacity { what: "d", max: 1, got: 2 })));
        let mut small_k = Predictor::<8, 4, 3, 16, 16>::empty(SqrtFlavour::Libm);
        assert_eq!(small_k.load(blob), Err(LoadError::Decode(Capacity { what: "k", max: 3, got: 4 })));
        let mut small_t = Predictor::<8, 4, 8, 6, 16>::empty(SqrtFlavour::Libm);
        assert_eq!(small_t.load(blob), Err(LoadError::Decode(Capacity { what: "lift terms", max: 6, got: 7 })));
        let mut small_h = Predictor::<8, 4, 8, 16, 8>::empty(SqrtFlavour::Libm);
        assert_eq!(small_h.load(blob), Err(LoadError::HistoryCapacity { needed: 9, max: 8 }));
        assert_eq!(small_h.predict(0), Err(PredictError::NoModel));
        // A failed decode keeps the loaded model.
        let mut p = loaded(SqrtFlavour::Libm);
        assert!(p.load(&blob[..n - 1]).is_err());
        assert_eq!(p.model().k(), 4);
        let m = Model::<8, 4, 8, 16>::decode(blob).unwrap();
        assert!(Predictor::<8, 4, 8, 16, 16>::from_model(m.clone(), SqrtFlavour::Libm).is_ok());
        assert_eq!(
            Predictor::<8, 4, 8, 16, 4>::from_model(m, SqrtFlavour::Libm).err(),
            Some(LoadError::HistoryCapacity { needed: 9, max: 4 })
        );
    }
}
