//! Which drive components the flight has moved so far, so that the sums skip the rest.
//!
//! A component that has been exactly zero in every sample so far (a planar craft's roll
//! torque, the rate products when the model has no gyroscopic term, a force no thruster
//! gives) contributes exactly zero to every product and every window sum: skipping it leaves
//! each sum bit for bit what adding its zeros would (`x + 0 = x` in every format here, and the
//! fixed kernel's integer sums are exact), for finite data. A sample with a non-finite value
//! (f32) is the exception: the dense products `0 * inf` would put NaN in the skipped entries,
//! which stay zero here; the sums are invalid either way and the fit refuses them alike. The set grows from the data, never from the
//! configuration: the first sample in which a component is other than zero (or not a valid
//! number) makes it active from that sample on, so a wrong guess cannot drop a product. Once
//! more than half are active the sums take their dense path (3-D craft after a few samples);
//! a planar craft keeps about 5 of the 18 and its tick the fraction of the products.

/// The active ones of `N` components, in increasing order (the lag-0 triangle needs
/// `i <= j`). `N` must be at most 255 (the list holds bytes; the user of `Active<NZ>` asserts
/// it at compile time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Active<const N: usize> {
    /// Component numbers; the first `len` are the active ones.
    list: [u8; N],
    len: u8,
    mask: [bool; N],
}

impl<const N: usize> Default for Active<N> {
    fn default() -> Self {
        Self::NONE
    }
}

impl<const N: usize> Active<N> {
    /// No component active (a flight before its first sample).
    pub const NONE: Self = Active {
        list: [0; N],
        len: 0,
        mask: [false; N],
    };

    /// Every component active (the dense path from the first sample).
    pub fn full() -> Self {
        let mut a = Self::NONE;
        a.grow(|_| true);
        a
    }

    /// True while few enough components are active that the sums skip the rest: at most
    /// half of them. Past that the dense loops, tuned for the M4F, cost less than the
    /// skipping (measured with 17 of 18 active on SPHERES: the f32 push 12,953 instructions
    /// instead of 5,951), and adding the zeros leaves the sums the same.
    pub fn sparse(&self) -> bool {
        usize::from(self.len) <= N / 2
    }

    /// True once every component is active.
    pub fn all(&self) -> bool {
        usize::from(self.len) >= N
    }

    /// The active components, increasing.
    pub fn components(&self) -> &[u8] {
        self.list.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// True if component `i` is active (while [`Active::sparse`]; past it the set is not kept).
    pub fn contains(&self, i: usize) -> bool {
        self.mask.get(i).copied().unwrap_or(false)
    }

    /// Makes active every component for which `nonzero(i)` says the sample's value is other
    /// than zero (or not a valid number). Once the set is past [`Active::sparse`] it stops
    /// growing: the sums then take every component, whatever the set says, and the tick is
    /// spared the scan.
    pub fn note(&mut self, nonzero: impl Fn(usize) -> bool) {
        if self.sparse() {
            self.grow(nonzero);
        }
    }

    /// Makes active every component `nonzero` names; the list rebuilt in order if it grew.
    fn grow(&mut self, nonzero: impl Fn(usize) -> bool) {
        let mut grew = false;
        for (i, m) in self.mask.iter_mut().enumerate() {
            if !*m && nonzero(i) {
                *m = true;
                grew = true;
            }
        }
        if grew {
            let mut len = 0u8;
            for (i, m) in self.mask.iter().enumerate() {
                if let (true, Some(slot), Ok(c)) =
                    (*m, self.list.get_mut(usize::from(len)), u8::try_from(i))
                {
                    *slot = c;
                    len = len.saturating_add(1);
                }
            }
            self.len = len;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    const NZ: usize = 18;

    #[test]
    fn components_stay_sorted_and_grow_only_from_nonzero_values() {
        let mut a = Active::<NZ>::NONE;
        assert!(a.components().is_empty() && !a.all());
        a.note(|i| i == 14 || i == 2);
        assert_eq!(a.components(), &[2, 14]);
        a.note(|i| i == 3);
        assert_eq!(a.components(), &[2, 3, 14]);
        assert!(a.contains(3) && !a.contains(4));
        a.note(|_| false);
        assert_eq!(a.components(), &[2, 3, 14]);
        a.note(|_| true);
        assert!(a.all() && !a.sparse());
        assert_eq!(a, Active::full());
        // Past half the components the set is not kept (the sums take every component).
        let mut b = Active::<NZ>::NONE;
        b.note(|i| i < NZ / 2 + 1);
        assert!(!b.sparse());
        b.note(|_| true);
        assert_eq!(b.components().len(), NZ / 2 + 1);
    }
}
