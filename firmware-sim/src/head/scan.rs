//! A scan: capture the sequence once into the frame-sequential decoder, then decode,
//! reconstruct, filter and stream the requested rows, serving the link between frames and rows.

use embedded_io::{Read, ReadReady, Write};
use fringe3d_core::decode::{DecodeConfig, Decoder, RowOut};
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::reconstruct::compiled::{FIELDS, PixelModel, SearchScratch, compiled_row};
use fringe3d_core::reconstruct::{Reconstructor, ReferenceRing, ReferenceRows};
use fringe3d_core::sequential::FrameDecoder as CaptureDecoder;
use fringe3d_core::validity::Validity;
use fringe3d_core::wire::{Command, HeadErrors, Message, NakCode, RowKind, ScanDone, ScanOutput};

use super::control::{PendingScan, compiled_base};
use super::dispatch::Link;
use super::error::{LinkError, ScanFail, hw_bit};
use super::sequence::{Lines, entry};
use super::transmit::{Stream, Tx};
use crate::hal::{BoardIo, Camera, HwError, Projector, Storage};
use crate::memory::{COMPILED_LINE_PER_COLUMN, HeadMemory};

/// How a scan ended.
enum ScanEnd {
    /// The counts of ScanDone over the rows streamed; `models_settled`: the scan read every row
    /// of its compiled models and settled none (`Control::compiled_settled`).
    Done {
        rows: u16,
        valid: u32,
        decoded: u32,
        searched: u32,
        models_settled: bool,
    },
    Aborted,
}

/// Run the planned scan `sc` to its end, serving the link between frames and rows, and end its
/// stream: ScanDone, or a Nak (Aborted; Internal with the fault's bit, in Fault for hardware).
pub(super) fn run<B: BoardIo, T: Read + ReadReady + Write>(
    board: &mut B,
    mem: &mut HeadMemory<'_>,
    link: &mut Link<'_>,
    io: &mut T,
    sc: PendingScan,
) -> Result<(), LinkError> {
    link.ctl.scanning = true;
    let res = capture_and_stream(board, mem, link, io, &sc);
    let Link { tx, ctl, .. } = link;
    ctl.scanning = false;
    ctl.abort = false;
    let cmd = Command::Scan as u8;
    match res {
        Ok(ScanEnd::Done {
            rows,
            valid,
            decoded,
            searched,
            models_settled,
        }) => {
            ctl.validated = true;
            // Unless the models were replaced while it ran.
            if models_settled && ctl.compiled_confirmed == sc.compiled {
                ctl.compiled_settled = true;
            }
            tx.reply(
                io,
                sc.seq,
                Message::ScanDone(ScanDone {
                    scan_id: sc.scan_id,
                    rows,
                    valid,
                    decoded,
                    searched,
                }),
                false,
            )
        }
        Ok(ScanEnd::Aborted) => tx.nak(io, sc.seq, cmd, NakCode::Aborted, 0),
        Err(ScanFail::Hw(e)) => {
            ctl.fault = true;
            ctl.errors |= hw_bit(e);
            tx.nak(io, sc.seq, cmd, NakCode::Internal, hw_bit(e) as u16)
        }
        Err(ScanFail::Internal) => {
            ctl.errors |= HeadErrors::INTERNAL;
            tx.nak(
                io,
                sc.seq,
                cmd,
                NakCode::Internal,
                HeadErrors::INTERNAL as u16,
            )
        }
        Err(ScanFail::Link(e)) => {
            // The port failed (on a desktop board: nobody read the line for too long). The scan
            // ends here: the head leaves Scanning, with the link error bit set.
            ctl.errors |= HeadErrors::LINK;
            Err(e)
        }
    }
}

/// Capture the sequence once into the frame-sequential decoder, then decode, reconstruct,
/// filter and stream rows `sc.first ..` of the scan.
fn capture_and_stream<B: BoardIo, T: Read + ReadReady + Write>(
    board: &mut B,
    mem: &mut HeadMemory<'_>,
    link: &mut Link<'_>,
    io: &mut T,
    sc: &PendingScan,
) -> Result<ScanEnd, ScanFail> {
    let slot = *link.ctl.usable(sc.slot).ok_or(ScanFail::Internal)?;
    let lut = link.ctl.lut.ok_or(ScanFail::Internal)?;
    let w = board.camera().width() as usize;
    let h = board.camera().height() as usize;
    let bits = board.camera().bit_depth() as u32;
    // The host's thresholds (DefineThresholds), else the camera bit depth's defaults.
    let config = slot
        .thresholds
        .map_or_else(|| DecodeConfig::for_bit_depth(bits), DecodeConfig::from);
    let mut decoder = Decoder::new(&sc.set, config).map_err(|_| ScanFail::Internal)?;
    if let Some(c) = &slot.correction {
        decoder
            .set_correction_knots(c.levels, |l, j| c.knot(l, j))
            .map_err(|_| ScanFail::Internal)?;
    }
    let plane = w * h;
    let state_len = CaptureDecoder::state_len(&decoder, w, h);
    let HeadMemory {
        decode_state,
        decode_flags,
        ring_phase,
        ring_validity,
        camera_line,
        projector_line,
        phase_row,
        modulation_row,
        dc_row,
        validity_row,
        xyz_rows,
        point_codes,
        reference_phase,
        reference_validity,
        compiled_line,
        compiled_codes,
    } = mem;
    let state = decode_state
        .get_mut(..state_len)
        .ok_or(ScanFail::Internal)?;
    let flags = decode_flags.get_mut(..plane).ok_or(ScanFail::Internal)?;
    let mut fd =
        CaptureDecoder::new(&decoder, w, h, state, flags).map_err(|_| ScanFail::Internal)?;
    let r = &mut link.ctl.report;
    r.decode_state = r.decode_state.max(state_len * 4);
    r.decode_flags = r.decode_flags.max(plane);
    let points = !matches!(sc.output, ScanOutput::Phase);
    // Camera line, decoded row; projector line; three point rows with their codes, the
    // reference row, and with the edge filter its output codes.
    // The reference map's rows: the image's width and its margin (`Reconstructor::with_margin`).
    let mw = match (points, sc.recon.as_ref()) {
        (true, Some(rc)) => rc.map_width(),
        _ => w,
    };
    let lines = w * (2 + 12 + 1)
        + board.projector().width() as usize
        + if points { w * 3 * 13 + mw * 5 } else { 0 }
        + if points && sc.filter.is_some() { w } else { 0 }
        + if sc.compiled.is_some() {
            w * (4 * COMPILED_LINE_PER_COLUMN + 2)
        } else {
            0
        };
    r.lines = r.lines.max(lines);

    // Capture: the sequence once per exposure (once with the entries' own without a list),
    // every camera-triggered frame into the decoder. Between exposures the decoder locks each
    // pixel that did not saturate (HDR, `FrameDecoder::next_exposure`); once none is left
    // saturated, the shorter exposures could change nothing and are not captured (the row
    // driver, `hdr::any_saturated`, stops there too).
    let mut lines_buf = Lines {
        camera: camera_line,
        projector: projector_line,
    };
    for pass in 0..sc.exposures.passes() {
        if pass > 0 {
            if !fd.saturated_left() {
                break;
            }
            fd.next_exposure().map_err(|_| ScanFail::Internal)?;
        }
        for i in 0..lut.len {
            link.pump(io, None::<&mut B>)?;
            if link.ctl.abort {
                return Ok(ScanEnd::Aborted);
            }
            let mut e = lut.entry(i).ok_or(ScanFail::Internal)?;
            if let (true, Some(us)) = (e.trigger_out, sc.exposures.of_pass(pass)) {
                e.exposure_us = us;
            }
            entry(board, &mut lines_buf, link.cfg, &slot, e, Some(&mut fd))?;
        }
        if !fd.is_complete() {
            return Err(ScanFail::Internal);
        }
    }

    // Output rows: decode, reconstruct, stream.
    let mut ring = None;
    let mut recon = None;
    if let (true, Some(rc)) = (points, sc.recon.as_ref()) {
        let rows = (rc.band().rows() as usize).min(rc.map_height());
        let rp = ring_phase.get_mut(..rows * mw).ok_or(ScanFail::Internal)?;
        let rv = ring_validity
            .get_mut(..rows * mw)
            .ok_or(ScanFail::Internal)?;
        ring = Some(ReferenceRing::new(rc, rp, rv).map_err(|_| ScanFail::Internal)?);
        recon = Some(rc);
        link.ctl.report.ring = link.ctl.report.ring.max(rows * mw * 5);
    }
    let (phase_row, modulation_row, dc_row, validity_row) = (
        &mut phase_row[..w],
        &mut modulation_row[..w],
        &mut dc_row[..w],
        &mut validity_row[..w],
    );
    let (xyz_rows, point_codes) = (&mut xyz_rows[..9 * w], &mut point_codes[..4 * w]);
    let (point_codes, filtered) = point_codes.split_at_mut(3 * w);
    let (Some(reference_phase), Some(reference_validity)) = (
        reference_phase.get_mut(..mw),
        reference_validity.get_mut(..mw),
    ) else {
        return Err(ScanFail::Internal);
    };
    // The compiled models (at the map store's end), a row of them staged in `models`, and the
    // search's outputs and input mask for the pixels they leave.
    let compiled = match sc.compiled.filter(|_| recon.is_some()) {
        Some(c) => {
            let base = compiled_base(board.map_store().capacity(), &c).ok_or(ScanFail::Internal)?;
            let (models, search_xyz) = compiled_line
                .get_mut(..COMPILED_LINE_PER_COLUMN * w)
                .ok_or(ScanFail::Internal)?
                .split_at_mut(FIELDS * w);
            let (search_codes, mask) = compiled_codes
                .get_mut(..2 * w)
                .ok_or(ScanFail::Internal)?
                .split_at_mut(w);
            Some(CompiledPass {
                models: Models {
                    base,
                    row_bytes: c.row_bytes(),
                    z: (c.z_min, c.z_max),
                },
                row: models,
                settle: !sc.compiled_settled,
                settled_rows: 0,
                search_xyz,
                search_codes,
                mask,
            })
        }
        None => None,
    };
    let mut compiled = compiled;
    let filter = sc.filter.filter(|_| recon.is_some());
    let end = sc.first.saturating_add(sc.count);
    let wanted = |r: u16| r >= sc.first && r < end;
    // With the edge filter, point row y needs rows y − 1 and y + 1 too: decode and
    // reconstruct one row beyond the range at each end (where the image has one), and emit
    // row y once row y + 1 is reconstructed. Point rows rotate through three slots.
    let (lo, hi) = match filter {
        Some(_) => (
            sc.first.saturating_sub(1),
            end.saturating_add(1).min(h as u16),
        ),
        None => (sc.first, end),
    };
    let stream = Stream {
        seq: sc.seq,
        scan_id: sc.scan_id,
    };
    // ScanDone's counts, over the rows streamed (not the filter's extra rows).
    let (mut valid, mut decoded, mut searched) = (0u32, 0u32, 0u32);
    let mut sent = 0u16;
    for y in lo..hi {
        link.pump(io, None::<&mut B>)?;
        if link.ctl.abort {
            return Ok(ScanEnd::Aborted);
        }
        fd.finish_row(
            y as usize,
            RowOut {
                phase: &mut *phase_row,
                modulation: &mut *modulation_row,
                dc: &mut *dc_row,
                validity: &mut *validity_row,
            },
        )
        .map_err(|_| ScanFail::Internal)?;
        if wanted(y) && matches!(sc.output, ScanOutput::Phase | ScanOutput::Both) {
            link.tx
                .rows(io, stream, y, RowKind::Phase, phase_row, validity_row, None)?;
        }
        let row_decoded = count_valid(validity_row);
        if wanted(y) {
            decoded = decoded.saturating_add(row_decoded);
        }
        let (Some(rc), Some(ring)) = (recon, ring.as_mut()) else {
            if wanted(y) {
                valid += row_decoded;
                sent += 1;
                link.ctl.rows_sent = link.ctl.rows_sent.wrapping_add(1);
            }
            continue;
        };
        let (_, last) = rc.rows_needed(y as u32);
        while ring.rows_pushed() <= last {
            read_reference_row(
                board.map_store(),
                ring.rows_pushed(),
                mw,
                reference_phase,
                reference_validity,
            )?;
            ring.push_row(reference_phase, reference_validity)
                .map_err(|_| ScanFail::Internal)?;
        }
        let k = y as usize % 3;
        let (xyz, codes) = (
            &mut xyz_rows[3 * w * k..3 * w * (k + 1)],
            &mut point_codes[w * k..w * (k + 1)],
        );
        let row_searched = match compiled.as_mut() {
            Some(cp) => {
                cp.row_into(board.map_store(), y)?;
                cp.reconstruct(rc, ring, y, phase_row, validity_row, xyz, codes)?
            }
            None => {
                rc.reconstruct_row(ring, y as u32, phase_row, validity_row, xyz, codes)
                    .map_err(|_| ScanFail::Internal)?;
                row_decoded
            }
        };
        if wanted(y) {
            searched = searched.saturating_add(row_searched);
        }
        // The point row now complete: y itself without the filter, else y − 1.
        let (done, below) = match filter {
            None => (Some(y), false),
            Some(_) => (y.checked_sub(1).filter(|&t| wanted(t)), true),
        };
        if let Some(t) = done {
            valid += emit_points(
                link.tx,
                io,
                stream,
                t,
                h,
                filter,
                below,
                xyz_rows,
                point_codes,
                filtered,
                w,
            )?;
            sent += 1;
            link.ctl.rows_sent = link.ctl.rows_sent.wrapping_add(1);
        }
    }
    // The image's last row has no row below: filter it now.
    if let (Some(_), Some(_)) = (filter, recon) {
        let t = end.saturating_sub(1);
        if end as usize == h && wanted(t) {
            valid += emit_points(
                link.tx,
                io,
                stream,
                t,
                h,
                filter,
                false,
                xyz_rows,
                point_codes,
                filtered,
                w,
            )?;
            sent += 1;
            link.ctl.rows_sent = link.ctl.rows_sent.wrapping_add(1);
        }
    }
    // Every row of the models read, none changed: later scans need not settle them.
    let models_settled = compiled
        .as_ref()
        .is_some_and(|cp| usize::from(cp.settled_rows) >= h);
    Ok(ScanEnd::Done {
        rows: sent,
        valid,
        decoded,
        searched,
        models_settled,
    })
}

/// Where the compiled models lie in the map store and what they were compiled for.
#[derive(Clone, Copy)]
struct Models {
    /// Byte offset of row 0 in the map store.
    base: u32,
    /// Bytes of one row (`40 × W`).
    row_bytes: u32,
    /// The depth range, mm.
    z: (f32, f32),
}

/// The compiled reconstruction of a scan (docs/compiled.md): a row of models read from the map
/// store, and the search's buffers for the pixels they leave to it.
struct CompiledPass<'a> {
    models: Models,
    row: &'a mut [f32],
    /// Settle each row read ([`PixelModel::settle_row_counted`]): until a whole scan has found
    /// every row of these models settled.
    settle: bool,
    /// Rows read and found settled, from the top, while none needed a change (with `settle`
    /// only: 0 otherwise).
    settled_rows: u16,
    search_xyz: &'a mut [f32],
    search_codes: &'a mut [u8],
    mask: &'a mut [u8],
}

impl CompiledPass<'_> {
    /// Read camera row `y`'s models from `store` into the staged row; while `settle`, make the
    /// models that are not usable the search's ([`PixelModel::settle_row_counted`]) and count
    /// the rows found settled. Once a whole scan has found them all settled (as `fringe3d`
    /// uploads them), the head reads its rows as they are: the settle cost a Cortex-M4F about
    /// as much as the kernel (docs/compiled.md).
    fn row_into<S: Storage>(&mut self, store: &mut S, y: u16) -> Result<(), ScanFail> {
        let m = self.models;
        let at = u32::from(y)
            .checked_mul(m.row_bytes)
            .and_then(|o| o.checked_add(m.base))
            .ok_or(HwError::Storage)?;
        read_f32s(store, at, self.row)?;
        if self.settle {
            let changed = PixelModel::settle_row_counted(self.row).ok_or(ScanFail::Internal)?;
            if changed == 0 && y == self.settled_rows {
                self.settled_rows = self.settled_rows.saturating_add(1);
            }
        }
        Ok(())
    }

    /// Point row `y` from its phases: the compiled models' points, and the §6 search's for the
    /// pixels they leave (`Reconstructor::search_left`, as the C ABI's
    /// `fringe3d_reconstruct_row_compiled` and the desktop's batch path do); how many they left.
    #[allow(clippy::too_many_arguments)]
    fn reconstruct<R: ReferenceRows + ?Sized>(
        &mut self,
        rc: &Reconstructor,
        ring: &R,
        y: u16,
        phase: &[f32],
        validity: &[u8],
        xyz: &mut [f32],
        codes: &mut [u8],
    ) -> Result<u32, ScanFail> {
        let (z_min, z_max) = self.models.z;
        let left = compiled_row(self.row, z_min, z_max, phase, validity, xyz, codes)
            .map_err(|_| ScanFail::Internal)?;
        if left == 0 {
            return Ok(0);
        }
        let scratch = SearchScratch {
            mask: self.mask,
            xyz: self.search_xyz,
            codes: self.search_codes,
        };
        rc.search_left(ring, u32::from(y), phase, validity, xyz, codes, scratch)
            .map_err(|_| ScanFail::Internal)?;
        Ok(left as u32)
    }
}

/// Read `out.len()` little-endian f32 from `store` at byte `at`.
fn read_f32s<S: Storage>(store: &mut S, at: u32, out: &mut [f32]) -> Result<(), HwError> {
    let mut buf = [0u8; 256];
    let mut off = at;
    for part in out.chunks_mut(buf.len() / 4) {
        let b = &mut buf[..4 * part.len()];
        store.read(off, b)?;
        for (dst, c) in part.iter_mut().zip(b.chunks_exact(4)) {
            *dst = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        off = off.checked_add(b.len() as u32).ok_or(HwError::Storage)?;
    }
    Ok(())
}

/// The number of valid points of a row (its validity codes).
fn count_valid(codes: &[u8]) -> u32 {
    codes
        .iter()
        .filter(|&&v| v == Validity::Valid as u8)
        .count() as u32
}

/// Stream point row `t` from its slot (`t % 3`) of `xyz_rows` / `codes`; with `filter`, first run
/// the edge filter over it with its neighbours (rows `t ± 1`, read from their slots; the
/// row below only if `below`), exactly as the desktop's `filter_edges`: flagged points become
/// canonical NaN. Returns the number of valid points sent.
#[allow(clippy::too_many_arguments)]
fn emit_points<T: Write>(
    tx: &mut Tx,
    io: &mut T,
    stream: Stream,
    t: u16,
    h: usize,
    filter: Option<EdgeFilter>,
    below: bool,
    xyz_rows: &[f32],
    codes: &[u8],
    filtered: &mut [u8],
    w: usize,
) -> Result<u32, ScanFail> {
    let slot = |r: usize| {
        let k = r % 3;
        (
            &xyz_rows[3 * w * k..3 * w * (k + 1)],
            &codes[w * k..w * (k + 1)],
        )
    };
    let t = t as usize;
    let cur = slot(t);
    let Some(f) = filter else {
        tx.rows(io, stream, t as u16, RowKind::Points, cur.0, cur.1, None)?;
        return Ok(count_valid(cur.1));
    };
    let above = (t > 0).then(|| slot(t - 1));
    let below = (below && t + 1 < h).then(|| slot(t + 1));
    if !f.filter_row(above, cur, below, filtered) {
        return Err(ScanFail::Internal);
    }
    tx.rows(
        io,
        stream,
        t as u16,
        RowKind::Points,
        cur.0,
        filtered,
        Some(cur.1),
    )?;
    Ok(count_valid(filtered))
}

/// Read row `r` (from the map's top) of the reference phase map, `w` samples wide (the image's
/// width and the map's margin), from `store` (phases LE, then validity codes).
fn read_reference_row<S: Storage>(
    store: &mut S,
    r: u32,
    w: usize,
    phase: &mut [f32],
    validity: &mut [u8],
) -> Result<(), HwError> {
    let row_bytes = (w * 5) as u32;
    let base = r.checked_mul(row_bytes).ok_or(HwError::Storage)?;
    let mut buf = [0u8; 256];
    let mut i = 0usize;
    while i < w {
        let n = (w - i).min(buf.len() / 4);
        let b = &mut buf[..4 * n];
        store.read(base + 4 * i as u32, b)?;
        for (dst, c) in phase[i..i + n].iter_mut().zip(b.chunks_exact(4)) {
            *dst = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        i += n;
    }
    store.read(base + 4 * w as u32, &mut validity[..w])
}
