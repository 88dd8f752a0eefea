//! Field 3 of the set-up blob: which pattern each captured image shows.
//!
//! On the wire (version 3) it is postcard bytes: a varint count, then one pattern index (u8) per
//! image, up to [`MAX_IMAGES`] (64). Versions 1 and 2 wrote a count u8 and always 32 indices
//! ([`legacy`](super::legacy) reads them).

use serde::de::{Error, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::SetupError;
use crate::pattern::{ImageId, MAX_IMAGES};
use crate::wire::message::PatternSetDesc;

/// Which pattern each captured image shows, in capture order: wire pattern indices (levels in
/// order, shifts in order within a level, as in a [`LutEntry`](crate::wire::LutEntry)). The head's
/// images arrive in this order; the core's default order is another numbering
/// ([`PatternSetDesc::pattern_id`] maps between them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CaptureOrder {
    /// Images captured: the set's pattern count.
    pub count: u8,
    /// Pattern index of each image; entries from `count` on are 0.
    pub patterns: [u8; MAX_IMAGES],
}

impl CaptureOrder {
    /// The capture order of images `order` of the set `desc` describes; `None` if an image is
    /// not in the set or there are more than [`MAX_IMAGES`].
    pub fn of(desc: &PatternSetDesc, order: &[ImageId]) -> Option<Self> {
        let mut c = CaptureOrder {
            count: u8::try_from(order.len()).ok()?,
            patterns: [0; MAX_IMAGES],
        };
        for (dst, id) in c.patterns.get_mut(..order.len())?.iter_mut().zip(order) {
            *dst = u8::try_from(desc.pattern_index(*id)?).ok()?;
        }
        Some(c)
    }

    /// The used entries (empty if `count` is out of range).
    pub fn used(&self) -> &[u8] {
        self.patterns.get(..self.count as usize).unwrap_or(&[])
    }

    /// Check that the order is a permutation of the `desc`'s patterns and unused entries are 0.
    pub fn validate(&self, desc: &PatternSetDesc) -> Result<(), SetupError> {
        let n = self.count as usize;
        let (Some(used), Some(unused)) = (self.patterns.get(..n), self.patterns.get(n..)) else {
            return Err(SetupError::CaptureOrder);
        };
        let mut seen = [false; MAX_IMAGES];
        let ok = n == desc.pattern_count()
            && n >= 1
            && unused.iter().all(|&p| p == 0)
            && used.iter().all(|&p| match seen.get_mut(p as usize) {
                Some(s) if (p as usize) < n && !*s => {
                    *s = true;
                    true
                }
                _ => false,
            });
        if ok {
            Ok(())
        } else {
            Err(SetupError::CaptureOrder)
        }
    }

    /// The core's image ids in capture order, and how many.
    pub fn image_ids(
        &self,
        desc: &PatternSetDesc,
    ) -> Result<([ImageId; MAX_IMAGES], usize), SetupError> {
        let mut ids = [ImageId { level: 0, shift: 0 }; MAX_IMAGES];
        let used = self.used();
        if used.len() != self.count as usize {
            return Err(SetupError::CaptureOrder);
        }
        for (dst, &p) in ids.iter_mut().zip(used) {
            *dst = desc.pattern_id(p as u16).ok_or(SetupError::CaptureOrder)?;
        }
        Ok((ids, used.len()))
    }
}

impl Serialize for CaptureOrder {
    /// The used entries as postcard bytes (varint count, then the indices). A count beyond
    /// [`MAX_IMAGES`] writes none; [`CaptureOrder::validate`] refuses it before any blob is
    /// written.
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.used())
    }
}

impl<'de> Deserialize<'de> for CaptureOrder {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_bytes(OrderVisitor)
    }
}

/// Reads [`CaptureOrder`]'s bytes; more than [`MAX_IMAGES`] is an error, not a truncation.
struct OrderVisitor;

impl Visitor<'_> for OrderVisitor {
    type Value = CaptureOrder;

    fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "at most {MAX_IMAGES} pattern indices")
    }

    fn visit_bytes<E: Error>(self, v: &[u8]) -> Result<CaptureOrder, E> {
        if v.len() > MAX_IMAGES {
            return Err(E::invalid_length(v.len(), &self));
        }
        let mut c = CaptureOrder {
            count: v.len() as u8,
            patterns: [0; MAX_IMAGES],
        };
        for (d, s) in c.patterns.iter_mut().zip(v) {
            *d = *s;
        }
        Ok(c)
    }
}
