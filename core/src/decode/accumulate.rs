//! Frame-sequential accumulation ([`Decoder::accumulate`]): each image row folded into the
//! caller's per-pixel state (the S, C and DC planes and the saturation flags) as frames arrive.
//! [`Decoder::finish`] turns the complete state into outputs.

use super::buffers::State;
#[cfg(doc)]
use super::decoder::SKIP;
use super::decoder::{ACC, Decoder, INIT};
use crate::arith::Arith;
use crate::decode_error::DecodeError;
use crate::sample::Sample;

impl<A: Arith> Decoder<A> {
    /// Fold the samples of image `image` (set order) into the state (the first half of the
    /// kernel). The state must have been zeroed before the first image.
    #[inline(always)]
    pub fn accumulate<P: Sample>(
        &self,
        image: usize,
        row: &[P],
        st: &mut State<'_, A::Acc>,
    ) -> Result<(), DecodeError> {
        self.accumulate_modes::<P, true, true>(image, row, st)
    }

    /// [`Self::accumulate`] with the plane modes of the image. `ZEROED`: the state was zeroed, so
    /// a first contribution may be added (the bits of `0 + k·v` either way); `FLAGS`: update the
    /// saturation flags.
    #[inline(always)]
    fn accumulate_modes<P: Sample, const ZEROED: bool, const FLAGS: bool>(
        &self,
        image: usize,
        row: &[P],
        st: &mut State<'_, A::Acc>,
    ) -> Result<(), DecodeError> {
        let coef = *self
            .images
            .get(image)
            .filter(|_| image < self.n_images)
            .ok_or(DecodeError::Sequence)?;
        let n = row.len();
        let l = coef.level as usize;
        if l == 0 && self.gray.is_some() {
            return self.accumulate_gray::<P, FLAGS>(image, row, st);
        }
        let (dc, flags) = (&mut st.dc[..], &mut st.flags[..]);
        let (s, c) = match (st.s.get_mut(l), st.c.get_mut(l)) {
            (Some(s), Some(c)) => (&mut s[..], &mut c[..]),
            _ => return Err(DecodeError::Sequence),
        };
        if dc.len() != n || s.len() != n || c.len() != n || (FLAGS && flags.len() != n) {
            return Err(DecodeError::Length);
        }
        let k = Coefs {
            a: coef.a,
            b: coef.b,
            w: coef.w,
            sat: self.limits.saturation,
        };
        let m = |x: u8| if ZEROED && x == INIT { ACC } else { x };
        let [ms, mc, mw] = coef.mode;
        // One loop per combination of plane modes (chosen per image by the plan, never by the
        // data), each a straight-line body over zipped slices that vectorizes.
        macro_rules! go {
            ($($a:literal $b:literal $c:literal),*) => {
                match (m(ms), m(mc), m(mw)) {
                    $(($a, $b, $c) => acc_loop::<A, P, $a, $b, $c, FLAGS>(row, s, c, dc, flags, &k),)*
                    _ => {}
                }
            };
        }
        go!(0 0 0, 0 0 1, 0 0 2, 0 1 0, 0 1 1, 0 1 2, 0 2 0, 0 2 1, 0 2 2,
            1 0 0, 1 0 1, 1 0 2, 1 1 0, 1 1 1, 1 1 2, 1 2 0, 1 2 1, 1 2 2,
            2 0 0, 2 0 1, 2 0 2, 2 1 0, 2 1 1, 2 1 2, 2 2 0, 2 2 1, 2 2 2);
        Ok(())
    }
}

impl<A: Arith> Decoder<A> {
    /// [`Self::accumulate`] of an image of the Gray-code level: its bit folded into the words in
    /// the level's S plane ([`Self::gray_fold`]), and the saturation flags.
    fn accumulate_gray<P: Sample, const FLAGS: bool>(
        &self,
        image: usize,
        row: &[P],
        st: &mut State<'_, A::Acc>,
    ) -> Result<(), DecodeError> {
        let n = row.len();
        let li = &self.level_images[0];
        let j = li
            .idx
            .iter()
            .take(li.n as usize)
            .position(|&k| k as usize == image)
            .ok_or(DecodeError::Sequence)?;
        let (dc, flags) = (&st.dc[..], &mut st.flags[..]);
        let (Some(plane), Some(pending)) = (st.s.get_mut(0), st.c.get_mut(0)) else {
            return Err(DecodeError::Sequence);
        };
        let (plane, pending) = (&mut plane[..], &mut pending[..]);
        if dc.len() != n || plane.len() != n || (FLAGS && flags.len() != n) {
            return Err(DecodeError::Length);
        }
        if pending.len() != n && self.gray.is_some_and(|g| g.inverse()) {
            return Err(DecodeError::Length);
        }
        self.gray_fold(j, row, dc, plane, pending)?;
        if FLAGS {
            let sat = self.limits.saturation;
            for (f, &v) in flags.iter_mut().zip(row) {
                *f |= A::saturated(A::input(v), sat) as u8;
            }
        }
        Ok(())
    }
}

/// The coefficients of one image and the saturation threshold, for [`acc_loop`].
struct Coefs<A: Arith> {
    a: A::Coef,
    b: A::Coef,
    w: A::Coef,
    sat: A::In,
}

/// Fold one image row into the S, C and DC planes with the plane modes `MS`, `MC`, `MW`
/// ([`SKIP`], [`INIT`], [`ACC`]), and into the saturation flags if `FLAGS`.
#[inline(always)]
fn acc_loop<A: Arith, P: Sample, const MS: u8, const MC: u8, const MW: u8, const FLAGS: bool>(
    row: &[P],
    s: &mut [A::Acc],
    c: &mut [A::Acc],
    dc: &mut [A::Acc],
    flags: &mut [u8],
    k: &Coefs<A>,
) {
    let n = row.len();
    let (s, c, dc) = (&mut s[..n], &mut c[..n], &mut dc[..n]);
    #[inline(always)]
    fn plane<A: Arith, const M: u8>(acc: &mut A::Acc, k: A::Coef, v: A::In) {
        if M == INIT {
            *acc = A::mac(A::ZERO, k, v);
        } else if M == ACC {
            *acc = A::mac(*acc, k, v);
        }
    }
    if FLAGS {
        let flags = &mut flags[..n];
        for i in 0..n {
            let v = A::input(row[i]);
            plane::<A, MS>(&mut s[i], k.a, v);
            plane::<A, MC>(&mut c[i], k.b, v);
            plane::<A, MW>(&mut dc[i], k.w, v);
            flags[i] |= A::saturated(v, k.sat) as u8;
        }
    } else {
        for i in 0..n {
            let v = A::input(row[i]);
            plane::<A, MS>(&mut s[i], k.a, v);
            plane::<A, MC>(&mut c[i], k.b, v);
            plane::<A, MW>(&mut dc[i], k.w, v);
        }
    }
}
