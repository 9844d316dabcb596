//! Typed indices into the pools.

/// Index of an element in an [`super::ElementPool`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct ElementId(pub u32);

/// Index of a link in a [`super::LinkPool`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct LinkId(pub u32);

impl ElementId {
    /// "No element" (e.g. the parent of a root).
    pub const NONE: ElementId = ElementId(u32::MAX);

    /// As a `usize` index.
    #[inline]
    pub fn ix(self) -> usize {
        self.0 as usize
    }

    /// True unless [`ElementId::NONE`].
    #[inline]
    pub fn is_some(self) -> bool {
        self.0 != u32::MAX
    }
}

impl LinkId {
    /// As a `usize` index.
    #[inline]
    pub fn ix(self) -> usize {
        self.0 as usize
    }
}
