//! Choosing the arithmetic at run time: [`Backend`] names one (tools, golden vectors,
//! benchmarks); `crate::decode::AnyDecoder` holds a decoder of any backend behind one type.

#[cfg(feature = "micromath")]
use super::F32Micromath;
use super::{Arith, F32Accurate, F32Fast, Fixed};

/// A decoding arithmetic, by name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// [`F32Accurate`], the default.
    #[default]
    F32Accurate,
    /// [`F32Fast`].
    F32Fast,
    /// [`F32Micromath`] (the core's `micromath` feature).
    #[cfg(feature = "micromath")]
    F32Micromath,
    /// [`Fixed`].
    Fixed,
}

impl Backend {
    /// Every backend, default first.
    #[cfg(feature = "micromath")]
    pub const ALL: [Backend; 4] = [
        Backend::F32Accurate,
        Backend::F32Fast,
        Backend::F32Micromath,
        Backend::Fixed,
    ];
    /// Every backend, default first (without the `micromath` feature's).
    #[cfg(not(feature = "micromath"))]
    pub const ALL: [Backend; 3] = [Backend::F32Accurate, Backend::F32Fast, Backend::Fixed];

    /// Its name: `f32`, `f32-fast`, `f32-micromath` or `fixed` ([`Arith::NAME`]).
    pub fn name(self) -> &'static str {
        match self {
            Backend::F32Accurate => F32Accurate::NAME,
            Backend::F32Fast => F32Fast::NAME,
            #[cfg(feature = "micromath")]
            Backend::F32Micromath => F32Micromath::NAME,
            Backend::Fixed => Fixed::NAME,
        }
    }

    /// The backend of a name ([`Backend::name`]).
    pub fn from_name(name: &str) -> Option<Backend> {
        Backend::ALL.into_iter().find(|b| b.name() == name)
    }
}

impl core::fmt::Display for Backend {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}
