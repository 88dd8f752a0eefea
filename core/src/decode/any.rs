//! A decoder whose arithmetic is chosen at run time ([`AnyDecoder`], named by a [`Backend`]):
//! tools, golden vectors, benchmarks, the parity workload ([`super::parity`]).

use super::buffers::RowOut;
use super::correction::PhaseCorrection;
use super::decoder::Decoder;
#[cfg(feature = "micromath")]
use crate::arith::F32Micromath;
use crate::arith::{Backend, F32Accurate, F32Fast, Fixed, FixedFormat};
use crate::decode_config::DecodeConfig;
use crate::decode_error::DecodeError;
use crate::pattern::PatternSet;
use crate::sample::Sample;

/// A decoder of any backend. Its methods are those of [`Decoder`], dispatched once per call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyDecoder {
    /// [`F32Accurate`].
    F32Accurate(Decoder<F32Accurate>),
    /// [`F32Fast`].
    F32Fast(Decoder<F32Fast>),
    /// [`F32Micromath`] (the core's `micromath` feature).
    #[cfg(feature = "micromath")]
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
            #[cfg(feature = "micromath")]
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
            #[cfg(feature = "micromath")]
            Backend::F32Micromath => AnyDecoder::F32Micromath(Decoder::with_arith(set, config)?),
            Backend::Fixed => AnyDecoder::Fixed(Decoder::with_arith(set, config)?),
        })
    }

    /// [`Decoder::with_correction`] in this backend.
    pub fn with_correction(self, c: &PhaseCorrection) -> Result<Self, DecodeError> {
        Ok(match self {
            AnyDecoder::F32Accurate(d) => AnyDecoder::F32Accurate(d.with_correction(c)?),
            AnyDecoder::F32Fast(d) => AnyDecoder::F32Fast(d.with_correction(c)?),
            #[cfg(feature = "micromath")]
            AnyDecoder::F32Micromath(d) => AnyDecoder::F32Micromath(d.with_correction(c)?),
            AnyDecoder::Fixed(d) => AnyDecoder::Fixed(d.with_correction(c)?),
        })
    }

    /// Which backend it runs.
    pub fn backend(&self) -> Backend {
        match self {
            AnyDecoder::F32Accurate(_) => Backend::F32Accurate,
            AnyDecoder::F32Fast(_) => Backend::F32Fast,
            #[cfg(feature = "micromath")]
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
