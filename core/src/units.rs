//! Checked newtypes for domain values.

/// A frequency in hertz: finite and strictly positive.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Hz(f32);

impl Hz {
    /// `Some` for a finite, strictly positive frequency.
    pub const fn new(hz: f32) -> Option<Self> {
        if hz.is_finite() && hz > 0.0 {
            Some(Self(hz))
        } else {
            None
        }
    }
    /// The value in hertz.
    pub const fn get(self) -> f32 {
        self.0
    }
    /// Shaft rate from revolutions per minute.
    pub const fn from_rpm(rpm: f32) -> Option<Self> {
        Self::new(rpm / 60.0)
    }
}

/// Index of a sensor node in a graph of `N` nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId<const N: usize>(u8);

impl<const N: usize> NodeId<N> {
    /// `Some` when `i < N` (and `N <= 256`).
    pub const fn new(i: usize) -> Option<Self> {
        if i < N && i <= u8::MAX as usize {
            Some(Self(i as u8))
        } else {
            None
        }
    }
    /// The index.
    pub const fn index(self) -> usize {
        self.0 as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn checked_constructors() {
        assert!(Hz::new(0.0).is_none());
        assert!(Hz::new(f32::NAN).is_none());
        assert!(Hz::new(-1.0).is_none());
        assert_eq!(Hz::from_rpm(1800.0).unwrap().get(), 30.0);
        assert!(NodeId::<3>::new(3).is_none());
        assert_eq!(NodeId::<3>::new(2).unwrap().index(), 2);
    }
}
