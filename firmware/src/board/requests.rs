//! The host's requests on the board: the bytes DMA2 channel 2 leaves
//! round the receive ring ([`super::link::receive`]), decoded into
//! requests and answered with the settings stored in flash
//! ([`instrument::commands`], [`super::flash`]). Each board application
//! with a settings store runs [`Requests::answer`] from its `idle`.

use super::flash::SettingsFlash;
use super::link::{Receiver, RxRing, RX_BYTES};
use crate::link_out::FrameWriter;
use instrument::commands::{Action, Commands};
use instrument::store::Store;

/// The receive ring, read only behind the DMA's position.
struct Ring(*const u8);

// SAFETY: the pointer is to a 'static ring; only the bytes the DMA has
// written are read (`Receiver::take`), with volatile reads.
#[allow(unsafe_code)]
unsafe impl Send for Ring {}

/// The request side of the link: the ring's reader, the frame decoder,
/// the commands and the store they answer from.
pub struct Requests {
    ring: Ring,
    rx: Receiver,
    decoder: ::link::Decoder,
    commands: Commands,
    store: Store<SettingsFlash>,
}

impl Requests {
    /// Over `ring`, which DMA2 channel 2 fills from now on, answering
    /// with `commands` from `store`.
    pub fn new(ring: &'static mut RxRing, commands: Commands, store: Store<SettingsFlash>) -> Self {
        Self {
            ring: Ring(ring.as_ptr()),
            rx: Receiver::new(),
            decoder: ::link::Decoder::new(),
            commands,
            store,
        }
    }

    /// The request the ring now holds whole, if one, answered through
    /// `writer` (one reply frame); then what the application must do.
    /// `remaining`: the receive channel's count
    /// ([`super::link::Transmitter::rx_remaining`]). The host sends one
    /// request and waits for its reply, so one a call is all there is.
    pub fn answer<const N: usize>(
        &mut self,
        remaining: u16,
        writer: &mut FrameWriter<'_, N>,
    ) -> Option<Action> {
        let ring = self.ring.0;
        // SAFETY: within the 'static ring of RX_BYTES; the DMA has
        // written these bytes and writes others.
        #[allow(unsafe_code)]
        let byte = |k: usize| unsafe { core::ptr::read_volatile(ring.add(k.min(RX_BYTES - 1))) };
        let decoder = &mut self.decoder;
        let mut request = None;
        self.rx.take(remaining, byte, |b| {
            if let Some(Ok(::link::Frame {
                seq,
                body: ::link::Body::Request(r),
            })) = decoder.push(b)
            {
                request = Some((seq, r));
            }
        });
        let (seq, req) = request?;
        Some(self.commands.handle(seq, &req, &mut self.store, |r| {
            writer.reply(r);
        }))
    }
}
