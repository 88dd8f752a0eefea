//! How the kernel fetches reference samples: the one step of the reconstruction that is data
//! movement only, behind a small trait so that a host can supply a wider gather.
//!
//! The kernel's search reads, for every lane of a chunk, the four samples of a bilinear cell:
//! two adjacent samples in one reference row and the two below them. The portable
//! [`ScalarGather`] reads them one by one (the compiler turns the loop into gather instructions
//! where the target has them). A host can read each adjacent pair as one 64-bit element instead
//! (half the gathered elements), e.g. with AVX-512 `vpgatherdq`; since an implementation only
//! moves values, every implementation gives the kernel the same inputs, and the reconstruction
//! the same bits. The tests compare them.

use super::LANES;
use crate::math::CANONICAL_NAN;

/// Fetches the samples of the bilinear cells of one chunk of [`LANES`] pixels.
pub trait CellGather: Copy {
    /// For every lane `i`, with `ja = min(ia[i], data.len() − 2)` and
    /// `jb = min(ib[i], data.len() − 2)`: `q[0][i] = data[ja]`, `q[1][i] = data[ja + 1]`,
    /// `q[2][i] = data[jb]`, `q[3][i] = data[jb + 1]`. With fewer than 2 samples in `data`, every
    /// output is the canonical NaN.
    fn gather(self, data: &[f32], ia: &[u32; LANES], ib: &[u32; LANES], q: [&mut [f32; LANES]; 4]);
}

/// The portable [`CellGather`]: one load per sample.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScalarGather;

impl CellGather for ScalarGather {
    #[inline(always)]
    fn gather(self, data: &[f32], ia: &[u32; LANES], ib: &[u32; LANES], q: [&mut [f32; LANES]; 4]) {
        let [qa, qb, qc, qd] = q;
        if data.len() < 2 {
            for o in [qa, qb, qc, qd] {
                *o = [CANONICAL_NAN; LANES];
            }
            return;
        }
        let last = data.len() - 2;
        for i in 0..LANES {
            let i0 = (ia[i] as usize).min(last);
            let i1 = (ib[i] as usize).min(last);
            qa[i] = data[i0];
            qb[i] = data[i0 + 1];
            qc[i] = data[i1];
            qd[i] = data[i1 + 1];
        }
    }
}
