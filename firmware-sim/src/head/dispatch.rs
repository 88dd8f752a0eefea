//! The command handler: bytes in, frames decoded, every request answered according to the
//! state machine (module docs of [`super`]).

use embedded_io::{Read, ReadReady, Write};
use fringe3d_core::wire::crc::Crc32c;
use fringe3d_core::wire::frame;
use fringe3d_core::wire::{
    Ack, Flags, FrameReceiver, HeadErrors, Header, Invalid, LUT_ENTRY_LEN, MAX_ENCODED_FRAME,
    MAX_LUT_ENTRIES, Message, Nak, NakCode, PROTOCOL_VERSION, UploadAck, UploadTarget,
    ValidationStatus, WireError, check_header,
};

use super::config::HeadConfig;
use super::control::{Control, Lut, POINTS_ONLY, Slot, Source, Upload, UploadKey, compiled_base};
use super::error::{LinkError, io_err};
use super::plan::plan_scan;
use super::transmit::Tx;
use crate::hal::{BoardIo, HwError, Storage};

/// The head's link side, borrowed apart from its board and memory: what answering frames needs.
pub(super) struct Link<'a> {
    /// The receive side: the frame decoder over its buffer.
    pub(super) rx: &'a mut FrameReceiver<[u8; MAX_ENCODED_FRAME]>,
    /// The transmit side.
    pub(super) tx: &'a mut Tx,
    /// The state machine.
    pub(super) ctl: &'a mut Control,
    /// The head's parameters.
    pub(super) cfg: &'a HeadConfig,
}

impl Link<'_> {
    /// Read every byte available, feed the frame decoder and answer each complete frame. `board`
    /// is `None` while a scan holds it (commands that need its stores are refused as busy).
    pub(super) fn pump<T: Read + ReadReady + Write, B: BoardIo>(
        &mut self,
        io: &mut T,
        mut board: Option<&mut B>,
    ) -> Result<bool, LinkError> {
        let Link { rx, tx, ctl, cfg } = self;
        let mut any = false;
        let mut buf = [0u8; 256];
        while io.read_ready().map_err(io_err)? {
            let n = io.read(&mut buf).map_err(io_err)?;
            if n == 0 {
                break;
            }
            any = true;
            let mut input = &buf[..n];
            while !input.is_empty() {
                let (used, event) = rx.feed(input);
                input = &input[used..];
                match event {
                    None => {}
                    Some(Err(_)) => {
                        ctl.rx_errors = ctl.rx_errors.wrapping_add(1);
                        ctl.errors |= HeadErrors::LINK;
                    }
                    Some(Ok(f)) => {
                        ctl.rx_frames = ctl.rx_frames.wrapping_add(1);
                        handle_frame(f, tx, ctl, cfg, io, board.as_deref_mut())?;
                    }
                }
            }
        }
        Ok(any)
    }
}

/// Parse one CRC-checked frame and dispatch it; malformed requests get a Nak echoing their seq.
fn handle_frame<T: Write, B: BoardIo>(
    f: &[u8],
    tx: &mut Tx,
    ctl: &mut Control,
    cfg: &HeadConfig,
    io: &mut T,
    board: Option<&mut B>,
) -> Result<(), LinkError> {
    // The CRC passed, so the header bytes are what the host sent.
    let (seq, cmd) = (
        f.get(2).copied().unwrap_or(0),
        f.get(3).copied().unwrap_or(0),
    );
    let (header, payload) = match frame::parse(f) {
        Ok(x) => x,
        Err(e) => {
            let nak = Nak::for_error(cmd, e);
            let detail = if matches!(e, WireError::Version(_)) {
                PROTOCOL_VERSION as u16
            } else {
                nak.detail
            };
            return tx.nak(io, seq, cmd, nak.code, detail);
        }
    };
    let msg = match Message::decode(header.command, payload) {
        Ok(m) => m,
        Err(e) => {
            let nak = Nak::for_error(cmd, e);
            return tx.nak(io, seq, cmd, nak.code, nak.detail);
        }
    };
    if check_header(&header, &msg).is_err() || !msg.command().is_request() {
        return tx.nak(io, seq, cmd, NakCode::Malformed, 0);
    }
    dispatch(tx, ctl, cfg, io, board, header, msg)
}

fn dispatch<T: Write, B: BoardIo>(
    tx: &mut Tx,
    ctl: &mut Control,
    cfg: &HeadConfig,
    io: &mut T,
    board: Option<&mut B>,
    h: Header,
    msg: Message<'_>,
) -> Result<(), LinkError> {
    let seq = h.seq;
    let cmd = h.command;
    let want = !msg.command().is_write() || h.flags.contains(Flags::REPLY_WANTED);
    let ack = Message::Ack(Ack { command: cmd });
    macro_rules! nak {
        ($code:expr, $detail:expr) => {
            return tx.nak(io, seq, cmd, $code, $detail as u16)
        };
    }
    macro_rules! reply {
        ($m:expr) => {
            return if want {
                tx.reply(io, seq, $m, false)
            } else {
                Ok(())
            }
        };
    }
    // Served in every state.
    match msg {
        Message::Hello(hello) => {
            if hello.protocol_version != PROTOCOL_VERSION {
                nak!(NakCode::Version, PROTOCOL_VERSION);
            }
            reply!(Message::Capabilities(ctl.caps));
        }
        Message::GetStatus => {
            let st = ctl.status(tx.frames);
            ctl.errors = 0;
            reply!(Message::Status(st));
        }
        Message::QueryUpload(t) => {
            if let Some(u) = ctl.upload_mut(t) {
                let next_offset = u.next;
                reply!(Message::UploadAck(UploadAck {
                    target: t,
                    next_offset
                }));
            }
            match ctl.confirmed(t) {
                Some(total) => reply!(Message::UploadAck(UploadAck {
                    target: t,
                    next_offset: total
                })),
                None => nak!(NakCode::NoUpload, 0),
            }
        }
        Message::ValidateSequence => {
            let v = ctl.validation(cfg);
            if !ctl.busy() && v & !POINTS_ONLY == 0 {
                ctl.validated = true;
            }
            reply!(Message::Validation(ValidationStatus(v)));
        }
        Message::Abort => {
            if ctl.scanning {
                ctl.abort = true;
            }
            ctl.running = None;
            if ctl.fault {
                ctl.fault = false;
                ctl.validated = false;
            }
            reply!(ack);
        }
        Message::Stop => {
            if ctl.scanning {
                nak!(NakCode::Busy, 0);
            }
            ctl.running = None;
            reply!(ack);
        }
        _ => {}
    }
    if !msg.command().is_request() {
        nak!(NakCode::Malformed, 0);
    }
    let Some(board) = board.filter(|_| !ctl.busy()) else {
        nak!(NakCode::Busy, 0);
    };
    match msg {
        Message::DefinePatternSet(d) => {
            if d.set_id >= ctl.caps.max_sets {
                nak!(NakCode::NoSuchSet, 0);
            }
            if d.desc.width != ctl.caps.projector_width
                || d.desc.height != ctl.caps.projector_height
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            let set = match d.desc.to_set() {
                Ok(s) => s,
                Err(why) => nak!(NakCode::Invalid, why),
            };
            let id = d.set_id;
            let same = matches!(&ctl.slots[id as usize], Some(s) if s.desc == d.desc);
            if !same {
                ctl.slots[id as usize] = Some(Slot {
                    desc: d.desc,
                    set,
                    source: Source::Generated,
                    correction: None,
                    thresholds: None,
                });
                if ctl.image_owner == Some(id) {
                    ctl.image_owner = None;
                }
                if matches!(ctl.pattern_upload, Some(u) if matches!(u.key, UploadKey::Patterns(b) if b.set_id == id))
                {
                    ctl.pattern_upload = None;
                }
                ctl.validated = false;
            }
            reply!(ack);
        }
        Message::DefineCorrection(c) => {
            let slot = ctl
                .slots
                .get_mut(c.set_id as usize)
                .and_then(|s| s.as_mut())
                .filter(|_| c.set_id < ctl.caps.max_sets);
            let Some(slot) = slot else {
                nak!(NakCode::NoSuchSet, 0);
            };
            if c.table.is_some_and(|t| t.levels != slot.desc.level_count) {
                nak!(NakCode::Invalid, Invalid::Correction);
            }
            slot.correction = c.table;
            ctl.validated = false;
            reply!(ack);
        }
        Message::DefineThresholds(d) => {
            let slot = ctl
                .slots
                .get_mut(d.set_id as usize)
                .and_then(|s| s.as_mut())
                .filter(|_| d.set_id < ctl.caps.max_sets);
            let Some(slot) = slot else {
                nak!(NakCode::NoSuchSet, 0);
            };
            slot.thresholds = d.thresholds;
            ctl.validated = false;
            reply!(ack);
        }
        Message::BeginUpload(b) => {
            let id = b.set_id;
            let Some(slot) = ctl
                .slots
                .get(id as usize)
                .copied()
                .flatten()
                .filter(|_| id < ctl.caps.max_sets)
            else {
                nak!(NakCode::NoSuchSet, 0);
            };
            let d = &slot.desc;
            if b.image_count as usize != d.pattern_count()
                || b.width != d.width
                || b.height != d.height
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            if b.bit_depth != d.bit_depth {
                nak!(NakCode::Invalid, Invalid::BitDepth);
            }
            if b.total_bytes > board.pattern_store().capacity() {
                nak!(NakCode::OutOfMemory, 0);
            }
            let key = UploadKey::Patterns(b);
            let next = match ctl.pattern_upload {
                Some(u) if u.key == key => u.next,
                _ => {
                    ctl.pattern_upload = Some(Upload { key, next: 0 });
                    if let Some(s) = ctl
                        .image_owner
                        .filter(|&o| o != id)
                        .and_then(|o| ctl.slots.get_mut(o as usize))
                        .and_then(|s| s.as_mut())
                    {
                        s.source = Source::Uploaded { confirmed: false };
                    }
                    ctl.image_owner = Some(id);
                    if let Some(s) = ctl.slots.get_mut(id as usize).and_then(|s| s.as_mut()) {
                        s.source = Source::Uploaded { confirmed: false };
                    }
                    ctl.validated = false;
                    0
                }
            };
            let target = UploadTarget::PatternSet(id);
            reply!(Message::UploadAck(UploadAck {
                target,
                next_offset: next
            }));
        }
        Message::BeginPhaseMapUpload(m) => {
            if m.width != ctl.caps.sensor_width || m.height != ctl.caps.sensor_height {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            // A map wider than the image (its margin) must fit the store and a staged row.
            if m.total_bytes > board.map_store().capacity()
                || m.map_width() as usize > ctl.reference_capacity
            {
                nak!(NakCode::OutOfMemory, 0);
            }
            // The compiled models were made from the map this one replaces.
            ctl.drop_compiled();
            let key = UploadKey::Map(m);
            let next = match ctl.map_upload {
                Some(u) if u.key == key => u.next,
                _ => {
                    ctl.map_upload = Some(Upload { key, next: 0 });
                    ctl.map_confirmed = None;
                    0
                }
            };
            reply!(Message::UploadAck(UploadAck {
                target: UploadTarget::PhaseMap,
                next_offset: next
            }));
        }
        Message::BeginCompiledUpload(m) => {
            // The models belong to one calibration and map: both first.
            let (Some(cal), Some(map)) = (ctl.calibration, ctl.map_confirmed) else {
                let mut missing = 0;
                if ctl.calibration.is_none() {
                    missing |= ValidationStatus::NO_CALIBRATION;
                }
                if ctl.map_confirmed.is_none() {
                    missing |= ValidationStatus::NO_REFERENCE;
                }
                nak!(NakCode::NotReady, missing);
            };
            if m.width != ctl.caps.sensor_width || m.height != ctl.caps.sensor_height {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            let g = &cal.geometry;
            if (m.z_min, m.z_max) != (g.depth_min as f32, g.depth_max as f32) {
                nak!(NakCode::Invalid, Invalid::DepthRange);
            }
            // A row of models must fit the line buffers, and the models the store beside the map.
            let room = compiled_base(board.map_store().capacity(), &m);
            if m.width as usize > ctl.compiled_capacity || room.is_none_or(|b| b < map.total_bytes)
            {
                nak!(NakCode::OutOfMemory, 0);
            }
            let key = UploadKey::Compiled(m);
            let next = match ctl.compiled_upload {
                Some(u) if u.key == key => u.next,
                _ => {
                    ctl.compiled_upload = Some(Upload { key, next: 0 });
                    ctl.compiled_confirmed = None;
                    ctl.compiled_settled = false;
                    0
                }
            };
            reply!(Message::UploadAck(UploadAck {
                target: UploadTarget::Compiled,
                next_offset: next
            }));
        }
        Message::UploadChunk(c) => {
            if c.data.len() > ctl.caps.max_chunk as usize {
                nak!(NakCode::Invalid, Invalid::ChunkSize);
            }
            let (store, base) = target_store(board, ctl, c.target);
            let Some((next, total)) = ctl.upload_mut(c.target).map(|u| (u.next, u.key.total()))
            else {
                nak!(NakCode::NoUpload, 0);
            };
            let end = c.offset as u64 + c.data.len() as u64;
            let mut next_offset = next;
            if c.offset == next {
                if end > total as u64 {
                    nak!(NakCode::Invalid, Invalid::Offset);
                }
                if store.write(base + c.offset, c.data).is_err() {
                    ctl.errors |= HeadErrors::MEMORY;
                    nak!(NakCode::Internal, HeadErrors::MEMORY);
                }
                next_offset = end as u32;
                if let Some(u) = ctl.upload_mut(c.target) {
                    u.next = next_offset;
                }
            } else if end > next as u64 {
                // Not at the current offset and not a repeat of bytes already stored.
                nak!(NakCode::BadOffset, 0);
            }
            reply!(Message::UploadAck(UploadAck {
                target: c.target,
                next_offset
            }));
        }
        Message::ConfirmUpload(t) => {
            let (store, base) = target_store(board, ctl, t);
            let Some(u) = ctl.upload_mut(t).copied() else {
                if ctl.confirmed(t).is_some() {
                    reply!(ack);
                }
                nak!(NakCode::NoUpload, 0);
            };
            if u.next != u.key.total() {
                nak!(NakCode::NotReady, 0);
            }
            let crc = match store_crc(store, base, u.key.total()) {
                Ok(c) => c,
                Err(_) => {
                    ctl.errors |= HeadErrors::MEMORY;
                    nak!(NakCode::Internal, HeadErrors::MEMORY);
                }
            };
            if crc != u.key.digest() {
                ctl.errors |= HeadErrors::UPLOAD;
                if let Some(u) = ctl.upload_mut(t) {
                    u.next = 0;
                }
                nak!(NakCode::DigestMismatch, 0);
            }
            match t {
                UploadTarget::PatternSet(id) => {
                    ctl.pattern_upload = None;
                    if let Some(s) = ctl.slots.get_mut(id as usize).and_then(|s| s.as_mut()) {
                        s.source = Source::Uploaded { confirmed: true };
                    }
                }
                UploadTarget::PhaseMap => {
                    ctl.map_upload = None;
                    ctl.map_confirmed = match u.key {
                        UploadKey::Map(m) => Some(m),
                        _ => None,
                    };
                }
                UploadTarget::Compiled => {
                    ctl.compiled_upload = None;
                    ctl.compiled_settled = false;
                    ctl.compiled_confirmed = match u.key {
                        UploadKey::Compiled(c) => Some(c),
                        _ => None,
                    };
                }
            }
            reply!(ack);
        }
        Message::UploadCalibration(cal) => {
            if cal.camera.width != u32::from(ctl.caps.sensor_width)
                || cal.camera.height != u32::from(ctl.caps.sensor_height)
            {
                nak!(NakCode::Invalid, Invalid::Dimension);
            }
            if let Err(why) = cal.camera_model() {
                nak!(NakCode::Invalid, why);
            }
            if ctl.calibration != Some(cal) {
                // The compiled models were made from the calibration this one replaces, and
                // the last scan's reconstructor was built from it.
                ctl.drop_compiled();
                ctl.recon_cache = None;
            }
            ctl.calibration = Some(cal);
            reply!(ack);
        }
        Message::ConfigureSequence(s) => {
            if s.set_id >= ctl.caps.max_sets {
                nak!(NakCode::NoSuchSet, 0);
            }
            let src = s.entries.as_bytes();
            let mut lut = Lut {
                bytes: [0; MAX_LUT_ENTRIES * LUT_ENTRY_LEN],
                len: s.entries.len(),
                set_id: s.set_id,
                repeat: s.repeat,
            };
            match lut.bytes.get_mut(..src.len()) {
                Some(dst) => dst.copy_from_slice(src),
                None => nak!(NakCode::Invalid, Invalid::LutLength),
            }
            ctl.lut = Some(lut);
            ctl.validated = false;
            reply!(ack);
        }
        Message::Start => {
            if ctl.fault {
                nak!(NakCode::NotReady, ctl.errors);
            }
            let v = ctl.validation(cfg) & !POINTS_ONLY;
            if v != 0 {
                nak!(NakCode::SequenceInvalid, v);
            }
            ctl.validated = true;
            ctl.running = Some(0);
            reply!(ack);
        }
        Message::Scan(req) => {
            if ctl.fault {
                nak!(NakCode::NotReady, ctl.errors);
            }
            match plan_scan(ctl, cfg, seq, req) {
                Ok(p) => {
                    if p.recon.is_some() {
                        ctl.recon_cache = p.recon;
                    }
                    ctl.pending = Some(p);
                    // The stream always starts with an Ack, whatever the flags.
                    tx.reply(io, seq, ack, true)
                }
                Err((code, detail)) => nak!(code, detail),
            }
        }
        _ => nak!(NakCode::Malformed, 0),
    }
}

/// The store an upload of `t` fills and where in it the upload's byte 0 lies: pattern images
/// at the start of the pattern store, the reference map at the start of the map store, the
/// compiled models at its end ([`compiled_base`]; 0 while no such upload is open).
fn target_store<'b, B: BoardIo>(
    board: &'b mut B,
    ctl: &Control,
    t: UploadTarget,
) -> (&'b mut B::Store, u32) {
    match t {
        UploadTarget::PatternSet(_) => (board.pattern_store(), 0),
        UploadTarget::PhaseMap => (board.map_store(), 0),
        UploadTarget::Compiled => {
            let store = board.map_store();
            let base = match ctl.compiled_upload.map(|u| u.key) {
                Some(UploadKey::Compiled(c)) => compiled_base(store.capacity(), &c).unwrap_or(0),
                _ => 0,
            };
            (store, base)
        }
    }
}

/// CRC-32C of the `len` bytes of `store` from `base`.
fn store_crc<S: Storage>(store: &mut S, base: u32, len: u32) -> Result<u32, HwError> {
    let mut crc = Crc32c::new();
    let mut buf = [0u8; 256];
    let mut at = 0u32;
    while at < len {
        let n = ((len - at) as usize).min(buf.len());
        store.read(base + at, &mut buf[..n])?;
        crc.update(&buf[..n]);
        at += n as u32;
    }
    Ok(crc.finish())
}
