//! Choosing the arithmetic at run time: [`Backend`] names one, [`AnyDecoder`] holds a decoder of
//! any backend behind one type (tools, golden vectors, benchmarks).

use super::{F32Accurate, F32Fast, F32Micromath, Fixed, FixedFormat};
use crate::arith::Arith;
use crate::decode::{DecodeConfig, DecodeError, Decoder, RowOut, Sample};
use crate::pattern::PatternSet;

/// A decoding arithmetic, by name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// [`F32Accurate`], the default.
    #[default]
    F32Accurate,
    /// [`F32Fast`].
    F32Fast,
    /// [`F32Micromath`].
    F32Micromath,
    /// [`Fixed`].
    Fixed,
}

impl Backend {
    /// Every backend, default first.
    pub const ALL: [Backend; 4] = [
        Backend::F32Accurate,
        Backend::F32Fast,
        Backend::F32Micromath,
        Backend::Fixed,
    ];

    /// Its name: `f32`, `f32-fast`, `f32-micromath` or `fixed` ([`Arith::NAME`]).
    pub fn name(self) -> &'static str {
        match self {
            Backend::F32Accurate => F32Accurate::NAME,
            Backend::F32Fast => F32Fast::NAME,
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

/// A decoder of any backend. Its methods are those of [`Decoder`], dispatched once per call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyDecoder {
    /// [`F32Accurate`].
    F32Accurate(Decoder<F32Accurate>),
    /// [`F32Fast`].
    F32Fast(Decoder<F32Fast>),
    /// [`F32Micromath`].
    F32Micromath(Decoder<F32Micromath>),
    /// [`Fixed`].
    Fixed(Decoder<Fixed>),
}

/// Runs `$body` with `$d` bound to the decoder inside.
macro_rules! dispatch {
    ($self:expr, $d:ident => $body:expr) => {
        match $self {
            AnyDecoder::F32Accurate($d) => $body,
            AnyDecoder::F32Fast($d) => $body,
            AnyDecoder::F32Micromath($d) => $body,
            AnyDecoder::Fixed($d) => $body,
        }
    };
}

impl AnyDecoder {
    /// Build the decoder of `set` in `backend` ([`Decoder::with_arith`]).
    pub fn new(
        set: &PatternSet,
        config: DecodeConfig,
        backend: Backend,
    ) -> Result<Self, DecodeError> {
        Ok(match backend {
            Backend::F32Accurate => AnyDecoder::F32Accurate(Decoder::with_arith(set, config)?),
            Backend::F32Fast => AnyDecoder::F32Fast(Decoder::with_arith(set, config)?),
            Backend::F32Micromath => AnyDecoder::F32Micromath(Decoder::with_arith(set, config)?),
            Backend::Fixed => AnyDecoder::Fixed(Decoder::with_arith(set, config)?),
        })
    }

    /// Which backend it runs.
    pub fn backend(&self) -> Backend {
        match self {
            AnyDecoder::F32Accurate(_) => Backend::F32Accurate,
            AnyDecoder::F32Fast(_) => Backend::F32Fast,
            AnyDecoder::F32Micromath(_) => Backend::F32Micromath,
            AnyDecoder::Fixed(_) => Backend::Fixed,
        }
    }

    /// The fixed-point format, for the [`Fixed`] backend.
    pub fn fixed_format(&self) -> Option<&FixedFormat> {
        match self {
            AnyDecoder::Fixed(d) => Some(d.format()),
            _ => None,
        }
    }

    /// [`Decoder::config`].
    pub fn config(&self) -> &DecodeConfig {
        dispatch!(self, d => d.config())
    }

    /// [`Decoder::level_count`].
    pub fn level_count(&self) -> usize {
        dispatch!(self, d => d.level_count())
    }

    /// [`Decoder::image_count`].
    pub fn image_count(&self) -> usize {
        dispatch!(self, d => d.image_count())
    }

    /// [`Decoder::decode_row`] in this backend.
    pub fn decode_row<P: Sample>(&self, rows: &[&[P]], out: RowOut<'_>) -> Result<(), DecodeError> {
        dispatch!(self, d => d.decode_row(rows, out))
    }

    /// [`Decoder::decode_row_level`] in this backend.
    pub fn decode_row_level<P: Sample>(
        &self,
        rows: &[&[P]],
        level: usize,
        wrapped: &mut [f32],
        modulation: &mut [f32],
    ) -> Result<(), DecodeError> {
        dispatch!(self, d => d.decode_row_level(rows, level, wrapped, modulation))
    }
}
