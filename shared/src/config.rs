//! Controller configuration: a gain vector over the measured coordinates, sampling, delay
//! and the effects (quantization, saturation, integral action) in physical units, as
//! designed on the host. The controller crate validates and converts it once (`try_new`),
//! the model blob carries it.

use serde::{Deserialize, Serialize};

/// Most measured coordinates a controller takes: the capacity of [`Gains`].
pub const MAX_GAINS: usize = 4;

/// State indices of the Furuta pendulum's (and the cart's) primary and secondary angles in
/// the plant state `[theta, theta_dot, phi, phi_dot]`: the coordinates of the shorthand
/// gains [`Gains::shorthand`].
pub const SHORTHAND_INDICES: (u8, u8) = (0, 2);

/// How the loop is spatially discretized.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum QuantMode {
    /// What a device does: each measured coordinate read as integer encoder counts
    /// `c = floor(q / h_adc)` with its own resolution, derivatives are count differences over
    /// `dt`, the law runs on integers, the output is an integer DAC code and `u = h_dac * code`.
    Counts,
    /// The paper's formula read literally: `u = h * floor(-sum_i [p_i*floor(q_i/h) +
    /// d_i*floor(qdot_i/h)])` with one step `h`, the first measured coordinate's `h_adc` (the
    /// DAC step and the other resolutions are ignored).
    Literal,
}

/// Spatial quantization of the loop; the encoder resolutions are per coordinate
/// ([`Gain::h_adc`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quantization {
    pub mode: QuantMode,
    /// DAC step, volts per code.
    pub h_dac: f64,
}

/// One measured coordinate `q_i = x[index]` of the plant state and its gains.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gain {
    /// Index of the coordinate in the plant state.
    pub index: u8,
    /// Proportional gain, V per unit of `q_i` (V/rad for an angle).
    pub p: f64,
    /// Derivative gain, V s per unit of `q_i`.
    pub d: f64,
    /// Encoder resolution, units of `q_i` per count: used, and required finite and > 0, by
    /// the quantized paths only (exact control reads no encoder).
    pub h_adc: f64,
}

/// The gain vector: at most [`MAX_GAINS`] measured coordinates, in the order the controller
/// reads them (the first one carries the integral action). Coordinates without an entry are
/// not measured. A fixed array and a length (`Copy`, no allocation); it dereferences to the
/// slice of its entries and is (de)serialized as that sequence.
#[derive(Clone, Copy)]
pub struct Gains {
    len: u8,
    items: [Gain; MAX_GAINS],
}

const UNUSED: Gain = Gain { index: 0, p: 0.0, d: 0.0, h_adc: 0.0 };

impl Gains {
    /// No coordinates (not a valid controller: add at least one with [`push`](Self::push)).
    pub const fn new() -> Self {
        Self { len: 0, items: [UNUSED; MAX_GAINS] }
    }

    /// The gains of an array of `K <= MAX_GAINS` entries (a compile-time check).
    // `i < K <= MAX_GAINS` bounds both indexings (const fn: no `get_mut`).
    #[allow(clippy::indexing_slicing)]
    pub const fn from_array<const K: usize>(a: [Gain; K]) -> Self {
        const { assert!(K <= MAX_GAINS, "more gains than MAX_GAINS") };
        let mut items = [UNUSED; MAX_GAINS];
        let mut i = 0;
        while i < K {
            items[i] = a[i];
            i += 1;
        }
        Self { len: K as u8, items }
    }

    /// Appends a coordinate; gives it back when the vector is full.
    pub fn push(&mut self, g: Gain) -> Result<(), Gain> {
        match self.items.get_mut(usize::from(self.len)) {
            Some(slot) => {
                *slot = g;
                self.len += 1;
                Ok(())
            }
            None => Err(g),
        }
    }

    /// Keeps the first `n` entries.
    pub fn truncate(&mut self, n: usize) {
        if n < usize::from(self.len) {
            for g in self.items.get_mut(n..).into_iter().flatten() {
                *g = UNUSED;
            }
            self.len = n as u8;
        }
    }

    /// The entries, in order.
    pub fn as_slice(&self) -> &[Gain] {
        self.items.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The entries, in order, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [Gain] {
        self.items.get_mut(..usize::from(self.len)).unwrap_or(&mut [])
    }
}

impl Default for Gains {
    fn default() -> Self {
        Self::new()
    }
}

impl core::ops::Deref for Gains {
    type Target = [Gain];
    fn deref(&self) -> &[Gain] {
        self.as_slice()
    }
}

impl core::ops::DerefMut for Gains {
    fn deref_mut(&mut self) -> &mut [Gain] {
        self.as_mut_slice()
    }
}

impl PartialEq for Gains {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl core::fmt::Debug for Gains {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list().entries(self.as_slice()).finish()
    }
}

impl Serialize for Gains {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.as_slice())
    }
}

impl<'de> Deserialize<'de> for Gains {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Gains;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "at most {MAX_GAINS} gains")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Gains, A::Error> {
                let mut g = Gains::new();
                while let Some(x) = seq.next_element::<Gain>()? {
                    if g.push(x).is_err() {
                        return Err(serde::de::Error::invalid_length(MAX_GAINS + 1, &self));
                    }
                }
                Ok(g)
            }
        }
        d.deserialize_seq(V)
    }
}

/// The shorthand gains of the Furuta pendulum and the cart: `kp`, `kd` on the primary angle
/// and `kphi_d` on the secondary one.
impl Gains {
    /// `[{index 0, p: kp, d: kd}, {index 2, p: 0, d: -kphi_d}]` with the encoder resolutions
    /// `h_adc` (primary) and `h_adc_phi` (secondary): the law `u = -kp*y - kd*ydot +
    /// kphi_d*zdot` of the Furuta and cart scenes.
    pub const fn shorthand(kp: f64, kd: f64, kphi_d: f64, h_adc: f64, h_adc_phi: f64) -> Self {
        let (y, z) = SHORTHAND_INDICES;
        Gains::from_array([
            Gain { index: y, p: kp, d: kd, h_adc },
            Gain { index: z, p: 0.0, d: -kphi_d, h_adc: h_adc_phi },
        ])
    }

    /// `(kp, kd, kphi_d)` when the vector has exactly the shorthand's layout.
    pub fn as_shorthand(&self) -> Option<(f64, f64, f64)> {
        let (y, z) = SHORTHAND_INDICES;
        match self.as_slice() {
            [a, b] if a.index == y && b.index == z && b.p == 0.0 => Some((a.p, a.d, -b.d)),
            _ => None,
        }
    }
}

/// A sampled-data PD/PID controller with zero-order hold and a delay of `delay` samples, on
/// the measured coordinates `q_i` of [`gains`](Self::gains):
///
/// `u_k = -sum_i [p_i q_i(k-r) + d_i (q_i(k-r) - q_i(k-r-1))/dt] - ki*x_I`
///
/// with `x_I` the running sum of `q_0(k-r)*dt` (the first measured coordinate).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerConfig {
    /// The measured coordinates and their gains, at least one.
    pub gains: Gains,
    /// Integral gain on the first measured coordinate, V/(unit s); 0 disables integral action.
    pub ki: f64,
    /// Sampling period, s.
    pub dt: f64,
    /// Feedback delay in samples (r; the paper uses 1).
    pub delay: u32,
    /// Output saturation |u| <= u_max, V; `None` for no saturation.
    pub u_max: Option<f64>,
    /// Spatial quantization; `None` for exact floating-point control.
    pub quant: Option<Quantization>,
}

impl ControllerConfig {
    /// The paper's gains (KP = 15.5 V, KD = 5.45 V s, KphiD = 1.5 V s) on the Furuta's
    /// angles, r = 1, no effects.
    pub const fn paper(dt: f64) -> Self {
        Self::shorthand(15.5, 5.45, 1.5, dt)
    }

    /// The shorthand law `u = -kp*y - kd*ydot + kphi_d*zdot` on the Furuta's (or the cart's)
    /// two angles, r = 1, no effects (encoder resolutions 0: set them with
    /// [`with_counts`](Self::with_counts) or [`with_resolutions`](Self::with_resolutions)).
    pub const fn shorthand(kp: f64, kd: f64, kphi_d: f64, dt: f64) -> Self {
        Self { gains: Gains::shorthand(kp, kd, kphi_d, 0.0, 0.0), ki: 0.0, dt, delay: 1, u_max: None, quant: None }
    }

    /// `(kp, kd, kphi_d)` when the gains have the shorthand's layout.
    pub fn as_shorthand(&self) -> Option<(f64, f64, f64)> {
        self.gains.as_shorthand()
    }

    /// The same configuration with the first coordinate's gains `p`, `d` (the shorthand's
    /// `kp`, `kd`); unchanged when there is no coordinate.
    pub fn with_primary(mut self, p: f64, d: f64) -> Self {
        if let Some(g) = self.gains.first_mut() {
            g.p = p;
            g.d = d;
        }
        self
    }

    /// The same configuration with the encoder resolutions `h[i]` on the gains, in order
    /// (extra entries of `h` are ignored, missing ones leave the gain's resolution).
    pub fn with_resolutions(mut self, h: &[f64]) -> Self {
        for (g, &h) in self.gains.iter_mut().zip(h) {
            g.h_adc = h;
        }
        self
    }

    /// The shorthand's quantization: counts mode, `h_adc` on the primary angle, `h_adc_phi`
    /// on the secondary one (applied in gain order), `h_dac` volts per code.
    pub fn with_counts(self, h_adc: f64, h_adc_phi: f64, h_dac: f64) -> Self {
        let mut c = self.with_resolutions(&[h_adc, h_adc_phi]);
        c.quant = Some(Quantization { mode: QuantMode::Counts, h_dac });
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shorthand_round_trips_and_other_layouts_are_not_shorthand() {
        let c = ControllerConfig::paper(0.025);
        assert_eq!(c.as_shorthand(), Some((15.5, 5.45, 1.5)));
        assert_eq!(c.gains.len(), 2);
        assert_eq!(c.gains[1].d, -1.5);
        let mut g = c.gains;
        g[1].p = 1.0;
        assert_eq!(g.as_shorthand(), None);
        g.truncate(1);
        assert_eq!(g.as_shorthand(), None);
        let q = c.with_counts(0.1, 0.2, 0.3);
        assert_eq!((q.gains[0].h_adc, q.gains[1].h_adc), (0.1, 0.2));
        assert_eq!(q.quant, Some(Quantization { mode: QuantMode::Counts, h_dac: 0.3 }));
    }
}
