//! The device's side of the link's requests ([`link::Request`]): read the
//! stored settings, write a new set in pieces and commit it, start, stop,
//! sweep the tones for a calibration step.
//! Each request is answered ([`link::Reply`]): acknowledged, or refused
//! with a reason, and then nothing changed. A new set is stored only by a
//! commit whose length and CRC match the pieces received in order, whose
//! bytes are a set of this layout, and which keeps every rule
//! ([`crate::stored::Stored::check`]); the store keeps the set in force
//! through any failure ([`crate::store`]).

use crate::store::{Staged, Store, StoreError};
use crate::stored::{Stored, MAX_BYTES};
use embedded_storage::nor_flash::NorFlash;
use link::{Chunk, Reason, Reply, Request, CHUNK};

/// The CRC-32 a commit of `bytes` carries.
pub fn crc(bytes: &[u8]) -> u32 {
    link::CRC.checksum(bytes)
}

/// What the application must do after a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Nothing more.
    None,
    /// Start measuring.
    Start,
    /// Stop measuring.
    Stop,
    /// A new set is in force: apply it.
    Apply,
    /// Sweep every tone pair, this many blocks each (a calibration
    /// step; [`crate::sweep::Sweep`]).
    Sweep(u16),
}

/// The new set being received: its pieces go straight to the store's
/// slot not in force ([`Store::begin`]), so a device holds no copy.
pub struct Commands {
    staged: Option<Staged>,
    /// The application sweeps tone pairs ([`Commands::sweeping`]).
    sweeps: bool,
}

impl Default for Commands {
    fn default() -> Self {
        Self::new()
    }
}

impl Commands {
    /// Nothing received; sweep requests refused as
    /// [`Reason::Unsupported`].
    pub const fn new() -> Self {
        Self {
            staged: None,
            sweeps: false,
        }
    }

    /// For an application that sweeps its tone pairs (the array): sweep
    /// requests acknowledged, [`Action::Sweep`].
    pub const fn sweeping() -> Self {
        Self {
            sweeps: true,
            ..Self::new()
        }
    }

    /// Answer request `req` (sequence number `seq`) with the settings in
    /// `store`, passing each reply to `reply` in order; what the
    /// application must do.
    pub fn handle<F: NorFlash>(
        &mut self,
        seq: u32,
        req: &Request,
        store: &mut Store<F>,
        mut reply: impl FnMut(Reply),
    ) -> Action
    where
        F::Error: crate::store::Corruption,
    {
        let ack = |generation| Reply::Ack { to: seq, generation };
        let refuse = |reason| Reply::Refused { to: seq, reason };
        let (outcome, action) = match *req {
            Request::Start => (Ok(0), Action::Start),
            Request::Stop => (Ok(0), Action::Stop),
            Request::Sweep { blocks_per_pair } => match self.sweep(blocks_per_pair) {
                Ok(action) => (Ok(0), action),
                Err(r) => (Err(r), Action::None),
            },
            Request::WriteChunk(chunk) => (self.write_chunk(&chunk, store).map(|()| 0), Action::None),
            Request::Commit { len, crc } => match self.commit(len, crc, store) {
                Ok(g) => (Ok(g), Action::Apply),
                Err(r) => (Err(r), Action::None),
            },
            Request::ReadSettings => {
                let read = read_settings(store, |chunk| reply(Reply::Chunk { to: seq, chunk }));
                (read, Action::None)
            }
        };
        reply(match outcome {
            Ok(g) => ack(g),
            Err(r) => refuse(r),
        });
        action
    }

    /// A sweep of `blocks_per_pair` blocks a tone pair, if this
    /// application sweeps and the count is within the link's range.
    fn sweep(&self, blocks_per_pair: u16) -> Result<Action, Reason> {
        if !self.sweeps {
            Err(Reason::Unsupported)
        } else if !(1..=link::SWEEP_MAX_BLOCKS).contains(&blocks_per_pair) {
            Err(Reason::OutOfRange)
        } else {
            Ok(Action::Sweep(blocks_per_pair))
        }
    }

    /// A piece of a set staged in flash: at 0 it begins a new set; any
    /// other continues the one staged, where its bytes end.
    fn write_chunk<F: NorFlash>(&mut self, chunk: &Chunk, store: &mut Store<F>) -> Result<(), Reason>
    where
        F::Error: crate::store::Corruption,
    {
        let data = chunk.data();
        let received = match chunk.offset {
            0 => Some(0),
            _ => self.staged.map(|s| s.len()),
        };
        let reason = match received {
            _ if usize::from(chunk.len) > CHUNK => Some(Reason::OutOfOrder),
            Some(n) if n == usize::from(chunk.offset) => {
                (n + data.len() > MAX_BYTES).then_some(Reason::TooLong)
            }
            _ => Some(Reason::OutOfOrder),
        };
        let staged = match (reason, self.staged.take()) {
            (Some(r), _) => Err(r),
            (None, Some(s)) if chunk.offset != 0 => Ok(s),
            (None, _) => store.begin().map_err(|_| Reason::Flash),
        };
        let mut staged = staged?;
        store.append(&mut staged, data).map_err(|_| Reason::Flash)?;
        self.staged = Some(staged);
        Ok(())
    }

    /// The staged set of `len` bytes and CRC `want` committed: its
    /// generation.
    fn commit<F: NorFlash>(&mut self, len: u16, want: u32, store: &mut Store<F>) -> Result<u32, Reason>
    where
        F::Error: crate::store::Corruption,
    {
        match self.staged.take() {
            Some(s) if usize::from(len) == s.len() => store.commit(s, want).map_err(|e| match e {
                StoreError::Mismatch => Reason::Mismatch,
                StoreError::Malformed => Reason::Malformed,
                StoreError::Refused(r) => setting(r),
                _ => Reason::Flash,
            }),
            // Nothing staged, or not as many bytes as the commit says.
            _ => Err(Reason::Mismatch),
        }
    }
}

/// The set in force, as pieces to `piece`: its generation.
fn read_settings<F: NorFlash>(store: &mut Store<F>, piece: impl FnMut(Chunk)) -> Result<u32, Reason>
where
    F::Error: crate::store::Corruption,
{
    match store.load() {
        Ok(Some(l)) => {
            let mut buf = [0u8; MAX_BYTES];
            let bytes = l.set.to_bytes(&mut buf).map_or(&[][..], |b| &*b);
            pieces(bytes, piece);
            Ok(l.generation)
        }
        Ok(None) => Err(Reason::NothingStored),
        Err(_) => Err(Reason::Flash),
    }
}

/// `bytes` as the link's pieces, in order.
pub fn pieces(bytes: &[u8], mut f: impl FnMut(Chunk)) {
    for (k, piece) in bytes.chunks(CHUNK).enumerate() {
        let mut chunk = Chunk {
            offset: (k * CHUNK) as u16,
            len: piece.len() as u8,
            bytes: [0; CHUNK],
        };
        chunk.bytes[..piece.len()].copy_from_slice(piece);
        f(chunk);
    }
}

/// A refused set's reason on the link.
fn setting(r: crate::stored::Refused) -> Reason {
    Reason::Setting {
        sensor: r.sensor.unwrap_or(255),
        rule: r.rule.code(),
    }
}

/// A set as the requests that store it: its pieces, then the commit.
pub fn upload(set: &Stored, mut request: impl FnMut(Request)) {
    let mut buf = [0u8; MAX_BYTES];
    let Some(bytes) = set.to_bytes(&mut buf) else {
        return;
    };
    pieces(bytes, |chunk| request(Request::WriteChunk(chunk)));
    request(Request::Commit {
        len: bytes.len() as u16,
        crc: crc(bytes),
    });
}

#[cfg(test)]
mod tests;
