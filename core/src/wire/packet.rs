//! Packets: a header and a message, to and from line bytes.

use super::frame::{self, CRC_LEN};
use super::header::{Flags, HEADER_LEN, Header};
use super::message::{Command, Message};
use super::{MAX_PAYLOAD, WireError};
use crate::wire::crc::crc32c;

/// A header with the message it carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Packet<'a> {
    /// The header (its `command` equals `message.command()`).
    pub header: Header,
    /// The message.
    pub message: Message<'a>,
}

impl<'a> Packet<'a> {
    /// A request with sequence number `seq`, [`Flags::REPLY_WANTED`] set.
    pub const fn request(seq: u8, message: Message<'a>) -> Self {
        let header = Header::for_message(&message, seq);
        Packet {
            header: Header {
                flags: header.flags.union(Flags::REPLY_WANTED),
                ..header
            },
            message,
        }
    }

    /// A reply to the request with header `to` (its `seq` echoed).
    pub const fn reply(to: &Header, message: Message<'a>) -> Self {
        Packet {
            header: Header::for_message(&message, to.seq),
            message,
        }
    }

    /// [`emit_packet`] of this packet.
    pub fn emit(&self, scratch: &mut [u8], out: &mut [u8]) -> Result<usize, WireError> {
        emit_packet(&self.header, &self.message, scratch, out)
    }

    /// [`parse_packet`] into a packet.
    pub fn parse(frame: &'a [u8]) -> Result<Self, WireError> {
        parse_packet(frame).map(|(header, message)| Packet { header, message })
    }
}

impl Header {
    /// The header for `message` with sequence number `seq`: its command, [`Flags::WRITE`] if the
    /// command writes, [`Flags::ERROR`] if it is a Nak, nothing else.
    pub const fn for_message(message: &Message<'_>, seq: u8) -> Header {
        let cmd = message.command();
        let flags = Flags::NONE
            .with(Flags::WRITE, cmd.is_write())
            .with(Flags::ERROR, matches!(cmd, Command::Nak));
        Header {
            flags,
            seq,
            command: cmd as u8,
            payload_len: 0,
        }
    }
}

/// Check the header's command and flags against the message.
///
/// [`WireError::CommandMismatch`] if the command byte is not the message's;
/// [`WireError::FlagMismatch`] if [`Flags::WRITE`] differs from
/// [`Command::is_write`] or [`Flags::ERROR`] is set on anything but a Nak (or clear on a Nak).
pub fn check_header(header: &Header, message: &Message<'_>) -> Result<(), WireError> {
    let cmd = message.command();
    if header.command != cmd as u8 {
        return Err(WireError::CommandMismatch);
    }
    let f = header.flags;
    if f.contains(Flags::WRITE) != cmd.is_write()
        || f.contains(Flags::ERROR) != matches!(cmd, Command::Nak)
    {
        return Err(WireError::FlagMismatch);
    }
    Ok(())
}

/// Serialise `message` under `header` into line bytes in `out`: header, postcard payload, CRC,
/// COBS, trailing `0x00`. Returns the number of bytes to send.
///
/// `header.payload_len` is ignored (computed). The header must agree with the message
/// ([`check_header`]; use [`Header::for_message`] or [`Packet::request`]/[`Packet::reply`]) and the
/// message must validate. `scratch` holds the decoded frame: it needs the payload length plus
/// [`frame::MIN_FRAME`] bytes ([`frame::MAX_FRAME`] always suffices); `out` needs
/// [`frame::MAX_ENCODED_FRAME`] at most. Errors: [`WireError::BufferTooSmall`],
/// [`WireError::PayloadTooLarge`], [`WireError::Invalid`], the two of [`check_header`].
pub fn emit_packet(
    header: &Header,
    message: &Message<'_>,
    scratch: &mut [u8],
    out: &mut [u8],
) -> Result<usize, WireError> {
    check_header(header, message)?;
    let body = scratch
        .get_mut(HEADER_LEN..)
        .ok_or(WireError::BufferTooSmall)?;
    let body_len = body.len();
    let n = message.encode(body)?;
    if n > MAX_PAYLOAD {
        return Err(WireError::PayloadTooLarge);
    }
    if n + CRC_LEN > body_len {
        return Err(WireError::BufferTooSmall);
    }
    let h = Header {
        payload_len: n as u16,
        ..*header
    };
    h.emit(scratch)?;
    let end = HEADER_LEN + n;
    let crc = crc32c(&scratch[..end]);
    scratch[end..end + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    frame::encode(&scratch[..end + CRC_LEN], out)
}

/// Parse a decoded frame (as yielded by [`FrameReceiver`](super::FrameReceiver)) into its header
/// and message, borrowing bulk data from `frame`.
///
/// Checks the length and CRC, the header ([`frame::parse`]), the command, the postcard body and
/// its validity ([`Message::decode`]) and header/message agreement ([`check_header`]). A head that
/// wants to answer a bad request with a Nak echoing its `seq` uses [`frame::parse`] and
/// [`Message::decode`] separately.
pub fn parse_packet(frame: &[u8]) -> Result<(Header, Message<'_>), WireError> {
    let (header, payload) = frame::parse(frame)?;
    let message = Message::decode(header.command, payload)?;
    check_header(&header, &message)?;
    Ok((header, message))
}
