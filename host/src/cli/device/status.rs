//! `fringe3d device info | start | stop | abort`: what the head is, holds and does, and the
//! trigger-sequence controls; the names of the head's state and bit-fields.

use super::{PortArgs, connect};
use crate::cli::Global;
use crate::device::{DeviceError, nak_reason};
use anyhow::{Context, Result, bail};
use fringe3d_core::wire::{HeadErrors, HeadState, Holds, NakCode};

/// A trigger-sequence control.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Control {
    /// `device start`.
    Start,
    /// `device stop`.
    Stop,
    /// `device abort`.
    Abort,
}

/// `device start | stop | abort`: send the command, then report the head's state.
pub(super) fn control(p: PortArgs, what: Control, g: Global) -> Result<()> {
    let mut c = connect(&p, None)?;
    let name = match what {
        Control::Start => "start",
        Control::Stop => "stop",
        Control::Abort => "abort",
    };
    let r = match what {
        Control::Start => c.start(),
        Control::Stop => c.stop(),
        Control::Abort => c.abort(),
    };
    match r {
        Err(DeviceError::Refused {
            code: NakCode::Busy,
            ..
        }) if what == Control::Stop => bail!(
            "the head is scanning: a scan is not stopped but aborted (`fringe3d device abort`)"
        ),
        r => r.with_context(|| format!("device {name} on {}", p.port))?,
    }
    let st = c.status()?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": format!("device {name}"), "port": p.port, "state": state_name(st.state),
                "errors": error_names(st.errors)})
        );
    } else if !g.quiet {
        let note = match (what, st.state) {
            (Control::Start, HeadState::Running) => "; `fringe3d device stop` or `abort` ends it",
            (Control::Start, _) => " (the sequence already ran to its end)",
            _ => "",
        };
        outln!("{name}: the head is {}{note}", state_name(st.state));
    }
    Ok(())
}

fn state_name(s: fringe3d_core::wire::HeadState) -> &'static str {
    use fringe3d_core::wire::HeadState::*;
    match s {
        Idle => "idle",
        Uploading => "uploading",
        Ready => "ready",
        Running => "running",
        Scanning => "scanning",
        Fault => "fault",
    }
}

fn error_names(e: HeadErrors) -> Vec<&'static str> {
    bit_names(
        e.0,
        &[
            (HeadErrors::LINK, "link"),
            (HeadErrors::UPLOAD, "upload"),
            (HeadErrors::TRIGGER_TIMEOUT, "trigger-timeout"),
            (HeadErrors::CAMERA, "camera"),
            (HeadErrors::PROJECTOR, "projector"),
            (HeadErrors::OVERRUN, "overrun"),
            (HeadErrors::MEMORY, "memory"),
            (HeadErrors::INTERNAL, "internal"),
        ],
    )
}

/// What the head holds ([`Holds`]), by name: `calibration`, `reference-map`, `compiled-models`.
fn holds_names(h: Holds) -> Vec<&'static str> {
    bit_names(
        h.0,
        &[
            (Holds::CALIBRATION, "calibration"),
            (Holds::REFERENCE, "reference-map"),
            (Holds::COMPILED, "compiled-models"),
        ],
    )
}

/// The names of the bits set in `bits`, in the table's order.
fn bit_names(bits: u32, names: &[(u32, &'static str)]) -> Vec<&'static str> {
    names
        .iter()
        .filter(|(b, _)| bits & b != 0)
        .map(|(_, n)| *n)
        .collect()
}

/// `device info`: capabilities, status (with what the head holds) and the sequence's
/// validation.
pub(super) fn info(p: PortArgs, g: Global) -> Result<()> {
    let mut c = connect(&p, None)?;
    let caps = *c.capabilities();
    let st = c.status()?;
    let v = c.validate()?;
    if g.json {
        outln!(
            "{}",
            serde_json::json!({"command": "device info", "port": p.port, "protocol_version": caps.protocol_version,
                "firmware": format!("{}.{}.{}", caps.firmware.major, caps.firmware.minor, caps.firmware.patch),
                "sensor": [caps.sensor_width, caps.sensor_height], "projector": [caps.projector_width, caps.projector_height],
                "free_memory": caps.free_memory, "max_chunk": caps.max_chunk, "max_sets": caps.max_sets, "max_lut_entries": caps.max_lut_entries,
                "state": state_name(st.state), "errors": error_names(st.errors), "rx_frames": st.rx_frames, "rx_errors": st.rx_errors,
                "tx_frames": st.tx_frames, "rows_sent": st.rows_sent, "holds": holds_names(st.holds), "validation": v.0})
        );
    } else if !g.quiet {
        outln!(
            "scan head on {}: protocol {}, firmware {}.{}.{}",
            p.port,
            caps.protocol_version,
            caps.firmware.major,
            caps.firmware.minor,
            caps.firmware.patch
        );
        outln!(
            "  camera {}x{}, projector {}x{}, {} bytes for uploads, chunks up to {} bytes, {} pattern-set slots, {} trigger entries",
            caps.sensor_width,
            caps.sensor_height,
            caps.projector_width,
            caps.projector_height,
            caps.free_memory,
            caps.max_chunk,
            caps.max_sets,
            caps.max_lut_entries
        );
        outln!(
            "  state {}, errors [{}], frames in {} (damaged {}), out {}, rows sent {}",
            state_name(st.state),
            error_names(st.errors).join(", "),
            st.rx_frames,
            st.rx_errors,
            st.tx_frames,
            st.rows_sent
        );
        let holds = holds_names(st.holds);
        outln!(
            "  holds: {}{}",
            if holds.is_empty() {
                "nothing".to_string()
            } else {
                holds.join(", ")
            },
            if st.holds.has(Holds::COMPILED) {
                " (points of pixels with a compiled model skip the search)"
            } else {
                ""
            }
        );
        if v.is_ok() {
            outln!("  sequence valid: ready to scan points");
        } else {
            outln!(
                "  sequence: {}",
                nak_reason(NakCode::SequenceInvalid, v.0 as u16)
            );
        }
    }
    Ok(())
}
