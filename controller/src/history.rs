//! Fixed-capacity delay line shared by the control paths (no allocation, no panics).

/// The last `H` samples, newest at `head`. Invariant kept by the owners: `back(k)` is only
/// called with `k < H` (the `try_new`s check `delay + 2 <= H`), and `H >= 2`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Delay<S: Copy + Default, const H: usize> {
    buf: [S; H],
    head: usize,
}

impl<S: Copy + Default, const H: usize> Delay<S, H> {
    pub(crate) fn new(fill: S) -> Self {
        Self { buf: [fill; H], head: 0 }
    }

    /// Every slot set to `s`.
    pub(crate) fn fill(&mut self, s: S) {
        self.buf = [s; H];
    }

    /// Make `s` the newest sample (`back(0)`).
    pub(crate) fn push(&mut self, s: S) {
        // head < H, so head + 1 cannot overflow; `% H` is a mask for power-of-two H.
        let next = self.head.wrapping_add(1) % H;
        if let Some(slot) = self.buf.get_mut(next) {
            *slot = s;
        }
        self.head = next;
    }

    /// What `back(k)` would return after `push(new)`, without pushing.
    pub(crate) fn back_after_push<'a>(&'a self, new: &'a S, k: usize) -> &'a S {
        match k.checked_sub(1) {
            None => new,
            Some(k1) => self.back_ref(k1).unwrap_or(new),
        }
    }

    /// The sample pushed `k` pushes before the newest (`back(0)` is the newest).
    #[cfg(test)]
    pub(crate) fn back(&self, k: usize) -> S {
        self.back_ref(k).copied().unwrap_or_default()
    }

    /// [`back`](Self::back) by reference; `None` only if `k >= H`, which the owners exclude.
    fn back_ref(&self, k: usize) -> Option<&S> {
        // head < H and k < H: head + H - k neither overflows nor underflows.
        let idx = self.head.wrapping_add(H).wrapping_sub(k) % H;
        self.buf.get(idx)
    }
}

impl<const H: usize> Delay<[i32; crate::MAX_GAINS], H> {
    /// Push `s`, of which only the first `N` entries are ever read (only those are written),
    /// and return the samples pushed `r` and `r + 1` pushes before the newest (`r + 2 <= H`,
    /// the owners' invariant): what [`back_after_push`](Self::back_after_push) gives for `r`
    /// and `r + 1` before the push.
    #[inline(always)]
    pub(crate) fn push_first_and_back<const N: usize>(
        &mut self,
        s: &[i32; crate::MAX_GAINS],
        r: usize,
    ) -> (&[i32; crate::MAX_GAINS], &[i32; crate::MAX_GAINS]) {
        const ZERO: [i32; crate::MAX_GAINS] = [0; crate::MAX_GAINS];
        let head = self.head.wrapping_add(1) % H;
        if let Some(slot) = self.buf.get_mut(head) {
            for (d, v) in slot.iter_mut().zip(s).take(N) {
                *d = *v;
            }
        }
        self.head = head;
        // head < H and r + 1 < H: neither index expression wraps below zero.
        let i0 = head.wrapping_add(H).wrapping_sub(r) % H;
        let i1 = head.wrapping_add(H).wrapping_sub(r.wrapping_add(1)) % H;
        (self.buf.get(i0).unwrap_or(&ZERO), self.buf.get(i1).unwrap_or(&ZERO))
    }
}

#[cfg(test)]
mod tests {
    use super::Delay;

    #[test]
    fn back_returns_pushed_samples_in_order_across_wraps() {
        let mut d: Delay<i32, 4> = Delay::new(-1);
        for i in 0..11 {
            assert_eq!(*d.back_after_push(&i, 0), i);
            d.push(i);
            for k in 0..4 {
                let expected = if i >= k as i32 { i - k as i32 } else { -1 };
                assert_eq!(d.back(k), expected, "after pushing {i}, back({k})");
                if k + 1 < 4 {
                    assert_eq!(*d.back_after_push(&(i + 1), k + 1), expected);
                }
            }
        }
    }
}
