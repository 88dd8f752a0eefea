//! Fixed-length arrays read exactly from TOML: serde's `[T; N]` takes the first `N` elements and
//! the toml crate ignores the rest, so a `distortion` of 6 values or a `normal` of 4 would load
//! with the extras silently dropped. The readers here refuse any other length with one error
//! naming the key (`` `normal` must have exactly 3 values, got 4 ``); surplus elements are
//! counted, not kept.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserialize, DeserializeSeed, Deserializer, IgnoredAny, SeqAccess, Visitor};

/// The array of exactly `N` elements at `key` (the name the error uses).
pub(crate) fn array<'de, D, T, const N: usize>(d: D, key: &'static str) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Exact::<PhantomData<T>, N> {
        key,
        unit: "values",
        elem: PhantomData,
    }
    .deserialize(d)
}

/// One entry of the list at `key`, an array of exactly `N` elements.
pub(crate) fn entry<'de, D, T, const N: usize>(d: D, key: &'static str) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Exact::<PhantomData<T>, N> {
        key,
        unit: "values per entry",
        elem: PhantomData,
    }
    .deserialize(d)
}

/// The `R × C` matrix at `key`: exactly `R` rows of exactly `C` elements each.
pub(crate) fn rows<'de, D, T, const R: usize, const C: usize>(
    d: D,
    key: &'static str,
) -> Result<[[T; C]; R], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let row = Exact::<PhantomData<T>, C> {
        key,
        unit: "values per row",
        elem: PhantomData,
    };
    Exact::<_, R> {
        key,
        unit: "rows",
        elem: row,
    }
    .deserialize(d)
}

/// A seed for (and the visitor of) an array of exactly `N` elements, each read with `elem`.
struct Exact<S, const N: usize> {
    /// The key, for messages.
    key: &'static str,
    /// What is counted, for messages ("values", "rows").
    unit: &'static str,
    elem: S,
}

impl<S: Clone, const N: usize> Clone for Exact<S, N> {
    fn clone(&self) -> Self {
        Exact {
            key: self.key,
            unit: self.unit,
            elem: self.elem.clone(),
        }
    }
}

impl<'de, S: DeserializeSeed<'de> + Clone, const N: usize> DeserializeSeed<'de> for Exact<S, N> {
    type Value = [S::Value; N];
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de, S: DeserializeSeed<'de> + Clone, const N: usize> Visitor<'de> for Exact<S, N> {
    type Value = [S::Value; N];

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: an array of {N} {}", self.key, self.unit)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut v = Vec::with_capacity(N);
        while v.len() < N {
            match seq.next_element_seed(self.elem.clone())? {
                Some(x) => v.push(x),
                None => return Err(wrong_length(&self, v.len())),
            }
        }
        let mut extra = 0usize;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            extra += 1;
        }
        if extra > 0 {
            return Err(wrong_length(&self, N + extra));
        }
        v.try_into()
            .map_err(|_| de::Error::custom(format!("`{}`: internal length error", self.key)))
    }
}

fn wrong_length<E: de::Error, S, const N: usize>(e: &Exact<S, N>, got: usize) -> E {
    E::custom(format!(
        "`{}` must have exactly {N} {}, got {got}",
        e.key, e.unit
    ))
}
