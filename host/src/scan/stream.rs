//! The streaming scan: decode, reconstruction (paper §6), the edge filter and the encoding
//! of the output file in one pass over bands of rows, bands in parallel, the file written in row
//! order while later bands are still being computed.
//!
//! Each band of rows `y0..y1` is computed by one worker on its own scratch buffers: the rows
//! `y0 − 1 .. y1 + 1` (one halo row each side, for the edge filter) are decoded
//! ([`crate::batch::decode_rows`]) and reconstructed ([`ScanCalibration::reconstruct_rows`]:
//! with the compiled models where the calibration has them, the band's rows of them read from
//! their file when they are [`super::CompiledModels::File`]) with the same kernels and the same
//! reference map as the whole-frame path, the rows `y0..y1` filtered
//! ([`EdgeFilter::filter_row`], which reads its neighbours' *input* codes, so a halo row gives the
//! same codes as the whole frame) and encoded by the writer's [`RowEncoder`]. A writer thread
//! hands the encoded bands to the sink in order. At most `window` bands are computed ahead of the
//! one being written, so the memory beyond the input images and the reference map is
//! O(`window` × band), whatever the image size: no full-frame intermediate exists.
//!
//! The file is the whole-frame path's byte for byte (`host/tests/scan_stream.rs`).

use super::{ScanCalibration, ScanCounts, ScanError};
use crate::batch::{FrameOut, Isa, PointsOut, decode_rows};
use crate::io::image_set::{Frames, ImageSet};
use crate::io::map_file::{MapFile, MapRows};
use crate::io::ply::{Encoded, PointRow, RowEncoder};
use fringe3d_core::decode::{Decoder, RowOut, Sample, hdr};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::reconstruct::{ReferenceMap, ReferenceRing};
use fringe3d_core::validity::Validity;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Number of validity codes.
const CODES: usize = Validity::ALL.len();

/// Pixels per band when [`StreamConfig::band_rows`] is 0: enough rows to make the two halo rows
/// a few per cent of the work, few enough that a band's buffers stay around a megabyte or two.
const BAND_PIXELS: usize = 1 << 15;

/// Rows of compiled models a worker reads from their file at a time
/// ([`super::CompiledModels::File`]): 44 bytes a pixel, so 8 rows of a 1280-pixel camera are
/// 450 KB, which stay in a core's cache between the read and the reconstruction.
pub const MODEL_ROWS: usize = 8;

/// How a streaming scan runs.
#[derive(Clone, Debug)]
pub struct StreamConfig {
    /// Rows per band; 0: about 65 536 pixels a band, and at least four bands per thread.
    pub band_rows: usize,
    /// Bands computed ahead of the one being written; 0: the thread count plus two.
    pub window: usize,
    /// The edge filter, or `None` to keep every point.
    pub edge_filter: Option<EdgeFilter>,
    /// The kernel variant (the same bits whichever).
    pub isa: Isa,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            band_rows: 0,
            window: 0,
            edge_filter: None,
            isa: Isa::detect(),
        }
    }
}

/// Thread time spent in each step, summed over the workers (seconds of one core each).
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTimes {
    /// Decoding (halo rows included).
    pub decode: Duration,
    /// Reconstruction (halo rows included).
    pub reconstruct: Duration,
    /// The edge filter.
    pub filter: Duration,
    /// Encoding the file's bytes.
    pub encode: Duration,
}

impl StepTimes {
    fn add(&mut self, o: &StepTimes) {
        self.decode += o.decode;
        self.reconstruct += o.reconstruct;
        self.filter += o.filter;
        self.encode += o.encode;
    }
}

/// What a streaming scan did.
#[derive(Clone, Debug)]
pub struct StreamStats {
    /// Pixels per validity code after the edge filter (index: `Validity as u8`).
    pub histogram: [usize; CODES],
    /// The pixels decoded and searched.
    pub counts: ScanCounts,
    /// Worker time per step, summed over the threads.
    pub steps: StepTimes,
    /// Time the writer thread spent in the sink (handing bytes to the file).
    pub write: Duration,
    /// Wall time of the whole pass.
    pub wall: Duration,
    /// Rows per band.
    pub band_rows: usize,
    /// Number of bands.
    pub bands: usize,
    /// Worker threads.
    pub threads: usize,
}

/// One computed band, waiting to be written.
struct BandOut {
    enc: Encoded,
    histogram: [usize; CODES],
    /// Its rows' counts.
    counts: ScanCounts,
}

/// What the workers and the writer share.
struct State {
    ready: BTreeMap<usize, BandOut>,
    /// Bands handed to the sink so far.
    written: usize,
    stop: bool,
    error: Option<ScanError>,
    steps: StepTimes,
    /// Encoded blocks handed back by the writer, for reuse.
    spare: Vec<Encoded>,
}

struct Shared {
    state: Mutex<State>,
    cv: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A poisoned lock means a worker panicked; the panic is re-raised by the scope.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn fail(&self, e: ScanError) {
        let mut s = self.lock();
        s.stop = true;
        s.error.get_or_insert(e);
        self.cv.notify_all();
    }
}

/// Stops the pass when a worker or the writer unwinds, so that nobody waits for it forever.
struct StopOnPanic<'a>(&'a Shared);

impl Drop for StopOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            let mut s = self.0.lock();
            s.stop = true;
            self.0.cv.notify_all();
        }
    }
}

/// A worker's buffers, reused band after band.
#[derive(Default)]
struct Scratch {
    phase: Vec<f32>,
    modulation: Vec<f32>,
    dc: Vec<f32>,
    decoded: Vec<u8>,
    xyz: Vec<f32>,
    codes: Vec<u8>,
    filtered: Vec<u8>,
    /// A shorter exposure's decode (HDR), folded into the above.
    shorter: [Vec<f32>; 3],
    shorter_codes: Vec<u8>,
    /// The map rows of the band, when the map is read from its file.
    map_rows: Vec<f32>,
    /// The compiled models of the band's rows, when they are read from their file.
    models: Vec<f32>,
    /// Per reconstructed row, the pixels the search computed ([`PointsOut::searched`]).
    searched: Vec<u32>,
}

/// Where the bands read the reference map from.
enum MapSource<'a> {
    /// The whole map, in memory.
    Whole(ReferenceMap<'a>),
    /// Its file: each band reads the rows it needs into a ring of its worker's.
    File(&'a MapFile),
}

/// What every band of one scan reads.
struct Job<'a, P> {
    cal: &'a ScanCalibration,
    map: MapSource<'a>,
    decoder: &'a Decoder,
    frames: &'a [&'a [P]],
    encoder: &'a RowEncoder,
    filter: Option<EdgeFilter>,
    isa: Isa,
    band_rows: usize,
}

impl<P: Sample> Job<'_, P> {
    /// HDR ([`fringe3d_core::decode::hdr`]): the decode of rows `a..` (`n` pixels) from the
    /// longest exposure, in `s`, takes each saturated pixel from the next shorter exposure, while
    /// any is left; a shorter exposure is decoded only for bands that need it.
    fn fuse_shorter_exposures(&self, a: usize, n: usize, s: &mut Scratch) -> Result<(), ScanError> {
        let images = self.decoder.image_count();
        let w = self.cal.width();
        for frames in self.frames.chunks_exact(images).skip(1) {
            if !hdr::any_saturated(&s.decoded[..n]) {
                break;
            }
            for v in &mut s.shorter {
                v.resize(n, 0.0);
            }
            s.shorter_codes.resize(n, 0);
            let [ph, mo, dc] = &mut s.shorter;
            decode_rows(
                self.decoder,
                frames,
                w,
                a,
                FrameOut {
                    phase: &mut ph[..n],
                    modulation: &mut mo[..n],
                    dc: &mut dc[..n],
                    validity: &mut s.shorter_codes[..n],
                },
                self.isa,
            )
            .map_err(ScanError::Decode)?;
            hdr::fuse_exposure(
                &mut RowOut {
                    phase: &mut s.phase[..n],
                    modulation: &mut s.modulation[..n],
                    dc: &mut s.dc[..n],
                    validity: &mut s.decoded[..n],
                },
                &hdr::RowRef {
                    phase: &ph[..n],
                    modulation: &mo[..n],
                    dc: &dc[..n],
                    validity: &s.shorter_codes[..n],
                },
            )
            .map_err(ScanError::Decode)?;
        }
        Ok(())
    }

    /// Compute band `b` into `out` (cleared first).
    fn band<'m>(
        &'m self,
        b: usize,
        s: &mut Scratch,
        reader: &mut Option<MapRows<'m>>,
        out: &mut BandOut,
        t: &mut StepTimes,
    ) -> Result<(), ScanError> {
        let (w, h) = (self.cal.width(), self.cal.height());
        let y0 = b * self.band_rows;
        let y1 = (y0 + self.band_rows).min(h);
        let halo = usize::from(self.filter.is_some());
        let (a, z) = (y0.saturating_sub(halo), (y1 + halo).min(h));
        let n = (z - a) * w;
        s.phase.resize(n, 0.0);
        s.modulation.resize(n, 0.0);
        s.dc.resize(n, 0.0);
        s.decoded.resize(n, 0);
        s.xyz.resize(3 * n, 0.0);
        s.codes.resize(n, 0);
        s.searched.resize(z - a, 0);
        let t0 = Instant::now();
        // The longest exposure (the only one without HDR); shorter ones where it saturated.
        let images = self.decoder.image_count();
        decode_rows(
            self.decoder,
            &self.frames[..images.min(self.frames.len())],
            w,
            a,
            FrameOut {
                phase: &mut s.phase[..n],
                modulation: &mut s.modulation[..n],
                dc: &mut s.dc[..n],
                validity: &mut s.decoded[..n],
            },
            self.isa,
        )
        .map_err(ScanError::Decode)?;
        self.fuse_shorter_exposures(a, n, s)?;
        let t1 = Instant::now();
        let recon = &self.cal.recon;
        let failed = |e| self.cal.reconstruction_error(e);
        let (phase, decoded) = (&s.phase[..n], &s.decoded[..n]);
        let band = PointsOut {
            xyz: &mut s.xyz[..3 * n],
            validity: &mut s.codes[..n],
            searched: Some(&mut s.searched[..z - a]),
        };
        let isa = self.isa;
        match &self.map {
            MapSource::Whole(map) => {
                (self.cal).reconstruct_rows(map, a, phase, decoded, band, &mut s.models, isa)?
            }
            MapSource::File(file) => {
                let rows = reader.get_or_insert_with(|| file.rows());
                // The map rows the band's camera rows read (paper §6's search band), and at
                // least as many as a ring must hold.
                let (r0, _) = recon.rows_needed(a as u32);
                let (_, r1) = recon.rows_needed((z - 1) as u32);
                let (r0, r1) = (r0 as usize, r1 as usize + 1);
                let held = (r1 - r0).max(recon.band().rows() as usize);
                s.map_rows.resize(held * recon.map_width(), 0.0);
                let mut ring =
                    ReferenceRing::new(recon, &mut s.map_rows, &mut []).map_err(failed)?;
                ring.start_at(r0 as u32).map_err(failed)?;
                rows.for_rows(r0, r1, |_, row| {
                    ring.push_row(row, &[]).map_err(|e| ScanError::Invalid {
                        path: file.path().to_path_buf(),
                        message: format!("reference map: {e}"),
                    })
                })?;
                (self.cal).reconstruct_rows(&ring, a, phase, decoded, band, &mut s.models, isa)?
            }
        }
        let t2 = Instant::now();
        // Row `y` of the band's buffers starts at `(y - a) * w`.
        let row = |y: usize| (y - a) * w..(y - a + 1) * w;
        let codes: &[u8] = match &self.filter {
            Some(f) => {
                s.filtered.resize((y1 - y0) * w, 0);
                let (xyz, val) = (&s.xyz, &s.codes);
                let input = |y: usize| {
                    let r = row(y);
                    (&xyz[3 * r.start..3 * r.end], &val[r])
                };
                for (y, o) in (y0..y1).zip(s.filtered.chunks_exact_mut(w)) {
                    let above = (y > 0).then(|| input(y - 1));
                    let below = (y + 1 < h).then(|| input(y + 1));
                    f.filter_row(above, input(y), below, o);
                }
                &s.filtered
            }
            None => &s.codes[row(y0).start..row(y1 - 1).end],
        };
        let t3 = Instant::now();
        out.enc.clear(y0 as u32);
        out.histogram = [0; CODES];
        for c in codes {
            out.histogram[(*c as usize).min(CODES - 1)] += 1;
        }
        // The band's own rows, not the halo's.
        let valid = Validity::Valid as u8;
        let decoded = &s.decoded[row(y0).start..row(y1 - 1).end];
        out.counts = ScanCounts {
            decoded: decoded.iter().filter(|&&c| c == valid).count(),
            searched: s.searched[y0 - a..y1 - a].iter().map(|&k| k as usize).sum(),
        };
        self.encoder.reserve(codes, &mut out.enc);
        let (xyz, _) = s.xyz.as_chunks::<3>();
        for (y, c) in (y0..y1).zip(codes.chunks_exact(w)) {
            let r = row(y);
            self.encoder.encode_row(
                &PointRow {
                    v: y as u32,
                    xyz: &xyz[r.clone()],
                    intensity: &s.dc[r.clone()],
                    modulation: &s.modulation[r],
                    validity: c,
                },
                &mut out.enc,
            )?;
        }
        let t4 = Instant::now();
        t.add(&StepTimes {
            decode: t1 - t0,
            reconstruct: t2 - t1,
            filter: t3 - t2,
            encode: t4 - t3,
        });
        Ok(())
    }
}

/// Rows per band for `threads` workers (see [`StreamConfig::band_rows`]).
fn auto_band_rows(w: usize, h: usize, threads: usize) -> usize {
    let by_size = (BAND_PIXELS / w.max(1)).max(4);
    let by_threads = h.div_ceil(4 * threads.max(1)).max(4);
    by_size.min(by_threads).min(h).max(1)
}

/// Scan a loaded image set in one streaming pass (see the module doc): every band's encoded
/// rows go to `sink` in row order, on a writer thread. On any error (the sink's included) no
/// further band is handed to the sink and the first error is returned.
pub fn stream_image_set(
    cal: &ScanCalibration,
    decoder: &Decoder,
    imgs: &ImageSet,
    encoder: &RowEncoder,
    cfg: &StreamConfig,
    sink: impl FnMut(&Encoded) -> Result<(), ScanError> + Send,
) -> Result<StreamStats, ScanError> {
    match &imgs.frames {
        Frames::U8(f) => {
            let fr: Vec<&[u8]> = f.iter().map(|v| v.as_slice()).collect();
            stream_frames(cal, decoder, &fr, encoder, cfg, sink)
        }
        Frames::U16(f) => {
            let fr: Vec<&[u16]> = f.iter().map(|v| v.as_slice()).collect();
            stream_frames(cal, decoder, &fr, encoder, cfg, sink)
        }
    }
}

/// [`stream_image_set`] over frames in memory (`frames[i]` is image `i` of the set, whole, of the
/// calibrated camera's size); the workers run on rayon's current pool. HDR: the set's images
/// once per exposure, longest exposure first (at most [`hdr::MAX_EXPOSURES`]), each pixel
/// decoded from the longest exposure in which it did not saturate.
pub fn stream_frames<P: Sample + Sync>(
    cal: &ScanCalibration,
    decoder: &Decoder,
    frames: &[&[P]],
    encoder: &RowEncoder,
    cfg: &StreamConfig,
    mut sink: impl FnMut(&Encoded) -> Result<(), ScanError> + Send,
) -> Result<StreamStats, ScanError> {
    let t0 = Instant::now();
    let (w, h) = (cal.width(), cal.height());
    let exposures = frames.len() / decoder.image_count().max(1);
    if frames.iter().any(|f| f.len() != w * h)
        || frames.len() != exposures * decoder.image_count()
        || !(1..=hdr::MAX_EXPOSURES).contains(&exposures)
    {
        return Err(ScanError::Decode(
            fringe3d_core::decode::DecodeError::Length,
        ));
    }
    let map = match &cal.reference_file {
        Some(f) => MapSource::File(f),
        None => MapSource::Whole(
            ReferenceMap::from_prepared(
                &cal.reference_phase,
                cal.recon.map_width(),
                cal.recon.map_height(),
            )
            .map_err(|e| ScanError::Invalid {
                path: cal.source.clone(),
                message: format!("reference map: {e}"),
            })?,
        ),
    };
    let threads = rayon::current_num_threads().max(1);
    let band_rows = match cfg.band_rows {
        0 => auto_band_rows(w, h, threads),
        r => r.min(h).max(1),
    };
    let bands = h.div_ceil(band_rows);
    let window = match cfg.window {
        0 => threads + 1,
        n => n,
    };
    let job = Job {
        cal,
        map,
        decoder,
        frames,
        encoder,
        filter: cfg.edge_filter,
        isa: cfg.isa,
        band_rows,
    };
    let shared = Shared {
        state: Mutex::new(State {
            ready: BTreeMap::new(),
            written: 0,
            stop: false,
            error: None,
            steps: StepTimes::default(),
            spare: Vec::new(),
        }),
        cv: Condvar::new(),
    };
    let next = AtomicUsize::new(0);
    let worker = || {
        let _guard = StopOnPanic(&shared);
        let mut scratch = Scratch::default();
        let mut reader = None;
        let mut steps = StepTimes::default();
        loop {
            let b = next.fetch_add(1, Ordering::Relaxed);
            if b >= bands {
                break;
            }
            let mut out = {
                let mut s = shared.lock();
                while b >= s.written + window && !s.stop {
                    s = shared.cv.wait(s).unwrap_or_else(|e| e.into_inner());
                }
                if s.stop {
                    break;
                }
                BandOut {
                    enc: s.spare.pop().unwrap_or_default(),
                    histogram: [0; CODES],
                    counts: ScanCounts::default(),
                }
            };
            match job.band(b, &mut scratch, &mut reader, &mut out, &mut steps) {
                Ok(()) => {
                    let mut s = shared.lock();
                    s.ready.insert(b, out);
                    shared.cv.notify_all();
                }
                Err(e) => {
                    shared.fail(e);
                    break;
                }
            }
        }
        shared.lock().steps.add(&steps);
    };
    let writer = || {
        let _guard = StopOnPanic(&shared);
        let mut histogram = [0usize; CODES];
        let mut counts = ScanCounts::default();
        let mut busy = Duration::ZERO;
        for b in 0..bands {
            let out = {
                let mut s = shared.lock();
                loop {
                    if let Some(o) = s.ready.remove(&b) {
                        break o;
                    }
                    if s.stop {
                        return (histogram, counts, busy);
                    }
                    s = shared.cv.wait(s).unwrap_or_else(|e| e.into_inner());
                }
            };
            let t = Instant::now();
            let res = sink(&out.enc);
            busy += t.elapsed();
            if let Err(e) = res {
                shared.fail(e);
                return (histogram, counts, busy);
            }
            for (a, c) in histogram.iter_mut().zip(out.histogram) {
                *a += c;
            }
            counts.add(out.counts);
            let mut s = shared.lock();
            s.written = b + 1;
            s.spare.push(out.enc);
            shared.cv.notify_all();
        }
        (histogram, counts, busy)
    };
    // The writer gets a thread of its own, outside rayon's pool: it waits for bands, and a pool
    // thread that waits would starve the workers of a one-thread pool.
    let (histogram, counts, write) = std::thread::scope(|ts| {
        let wr = ts.spawn(writer);
        rayon::scope(|s| {
            for _ in 0..threads.min(bands) {
                s.spawn(|_| worker());
            }
        });
        wr.join()
    })
    .unwrap_or_else(|p| std::panic::resume_unwind(p));
    let st = shared.state.into_inner().unwrap_or_else(|e| e.into_inner());
    if let Some(e) = st.error {
        return Err(e);
    }
    Ok(StreamStats {
        histogram,
        counts,
        steps: st.steps,
        write,
        wall: t0.elapsed(),
        band_rows,
        bands,
        threads,
    })
}
