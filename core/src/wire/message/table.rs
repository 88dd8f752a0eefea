//! The command table macro: one line per command (id, direction, body) gives [`Command`] and its
//! byte values, names and classification, [`Message`] and its encode / decode / validate
//! dispatch, so adding a command is one line in `mod.rs` (as smoltcp's `enum_with_unknown!`
//! does for its protocol enums).
//!
//! A table line reads
//!
//! ```text
//! /// Command docs.
//! Name = 0xID => direction(Body), "Message variant docs.";
//! ```
//!
//! `direction` is `read` (a request that changes nothing), `write` (a request that changes the
//! head's state: its frames carry WRITE) or `reply` (head → host). `Body` is the postcard-encoded
//! payload type; `()` means an empty payload and a unit variant of [`Message`]. Requests must have
//! ids below `0x80`, replies `0x80` and up, and ids must be distinct: both are checked at compile
//! time.

#[cfg(doc)]
use super::{Command, Message};

/// `true` for the request directions.
macro_rules! direction_is_request {
    (read) => {
        true
    };
    (write) => {
        true
    };
    (reply) => {
        false
    };
}

/// `true` for requests that change the head's state.
macro_rules! direction_is_write {
    (read) => {
        false
    };
    (write) => {
        true
    };
    (reply) => {
        false
    };
}

/// The pattern of a [`Message`] variant, binding its body (if any) to `$m`.
macro_rules! body_pattern {
    ($v:ident () $m:ident) => {
        Message::$v
    };
    ($v:ident ($b:ty) $m:ident) => {
        Message::$v($m)
    };
}

/// The first block for a command with a body, the second for an empty one.
macro_rules! with_body {
    (() { $($with:tt)* } { $($without:tt)* }) => {
        $($without)*
    };
    (($b:ty) { $($with:tt)* } { $($without:tt)* }) => {
        $($with)*
    };
}

/// The command table: see the module docs.
macro_rules! commands {
    ($(
        $(#[doc = $doc:literal])*
        $name:ident = $id:literal => $dir:ident ( $($body:ty)? ), $mdoc:literal;
    )*) => {
        /// Command ids, the header's byte 3. Requests (host → head) are `0x00..=0x7F`, replies
        /// and notifications (head → host) `0x80..=0xFF`.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[repr(u8)]
        pub enum Command {
            $( $(#[doc = $doc])* $name = $id, )*
        }

        // Requests below 0x80, replies from 0x80 on, ids distinct.
        const _: () = {
            let all = [$( ($id as u8, direction_is_request!($dir)) ),*];
            let mut i = 0;
            while i < all.len() {
                assert!(all[i].1 == (all[i].0 < 0x80), "a request id >= 0x80 or a reply id < 0x80");
                let mut j = i + 1;
                while j < all.len() {
                    assert!(all[i].0 != all[j].0, "two commands share an id");
                    j += 1;
                }
                i += 1;
            }
        };

        impl Command {
            /// Every command, in table (id) order.
            pub const ALL: [Command; [$($id as u8),*].len()] = [$(Command::$name),*];

            /// The command with id `id`, if any.
            pub const fn from_u8(id: u8) -> Option<Command> {
                match id {
                    $( $id => Some(Command::$name), )*
                    _ => None,
                }
            }

            /// The command's name, as in the protocol table (`"Hello"`, `"UploadChunk"`, …).
            pub const fn name(self) -> &'static str {
                match self {
                    $( Command::$name => stringify!($name), )*
                }
            }

            /// `true` for host → head requests (ids below `0x80`).
            pub const fn is_request(self) -> bool {
                match self {
                    $( Command::$name => direction_is_request!($dir), )*
                }
            }

            /// `true` for requests that change the head's state: their frames carry
            /// [`Flags::WRITE`](crate::wire::Flags::WRITE), all others must not.
            pub const fn is_write(self) -> bool {
                match self {
                    $( Command::$name => direction_is_write!($dir), )*
                }
            }
        }

        /// Every message, request or reply. The variant's [`Command`] is the header's command
        /// byte; its body, postcard-encoded, is the payload (empty for the unit variants).
        ///
        /// About 1.4 KB, nearly all of it the pattern-set variant; without alloc there is nothing
        /// to box it into, and a head keeps one message at a time.
        #[allow(clippy::large_enum_variant)]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub enum Message<'a> {
            $( #[doc = $mdoc] $name $( ($body) )?, )*
        }

        impl<'a> Message<'a> {
            /// The command id of this message.
            pub const fn command(&self) -> Command {
                match self {
                    $( Message::$name { .. } => Command::$name, )*
                }
            }

            /// Check every field of the body ([`WireError::Invalid`] says which rule failed).
            pub fn validate(&self) -> Result<(), WireError> {
                match self {
                    $(
                        body_pattern!($name ($($body)?) m) =>
                            with_body!(($($body)?) { Body::validate_body(m) } { Ok(()) }),
                    )*
                }
            }

            /// Validate, then postcard-encode the body into `out`; returns the payload length.
            ///
            /// [`WireError::BufferTooSmall`] if `out` is too short; [`WireError::PayloadTooLarge`]
            /// if the payload would exceed [`MAX_PAYLOAD`].
            pub fn encode(&self, out: &mut [u8]) -> Result<usize, WireError> {
                self.validate()?;
                let limited = out.len() > MAX_PAYLOAD;
                let out = if limited {
                    &mut out[..MAX_PAYLOAD]
                } else {
                    out
                };
                let r = match self {
                    $(
                        body_pattern!($name ($($body)?) m) =>
                            with_body!(($($body)?) { ser(m, out) } { Ok(0) }),
                    )*
                };
                match r {
                    Err(WireError::BufferTooSmall) if limited => Err(WireError::PayloadTooLarge),
                    r => r,
                }
            }

            /// Decode the payload of a frame with command id `command`, then validate it.
            ///
            /// [`WireError::UnknownCommand`], [`WireError::Payload`] (postcard failed),
            /// [`WireError::TrailingBytes`] (bytes left after the body), [`WireError::Invalid`].
            pub fn decode(command: u8, payload: &'a [u8]) -> Result<Message<'a>, WireError> {
                let cmd = Command::try_from(command)?;
                if payload.len() > MAX_PAYLOAD {
                    return Err(WireError::PayloadTooLarge);
                }
                let p = payload;
                let msg = match cmd {
                    $(
                        Command::$name => with_body!(($($body)?)
                            { Message::$name(de(p)?) }
                            { empty(p).map(|_| Message::$name)? }),
                    )*
                };
                msg.validate()?;
                Ok(msg)
            }
        }
    };
}
