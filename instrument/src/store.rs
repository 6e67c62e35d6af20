//! The stored settings ([`Stored`]) in flash, in two slots (A/B), so that
//! power lost at any instant of an update leaves either the set in force
//! or the new one, never a corrupt one and never none.
//!
//! A slot is whole erase pages: a header, then the set's postcard bytes.
//! An update goes to the slot not in force: erase it, write the body,
//! then the header last, carrying a generation one above the one in force
//! and the CRC-32 of the body, itself closed by its own CRC. At start the
//! valid slot with the newer generation is the set in force; a slot whose
//! header or body does not check (never written, half erased, half
//! written) is not valid. The slot in force is never written, so a cut
//! anywhere in an update leaves it as it was.
//!
//! Why two slots and not `sequential-storage`: its updates are atomic per
//! item, and a set (about 2 KiB) is larger than an item fits on the
//! G474's 2 KiB pages; splitting it into items would give up the "old or
//! new, never a mix" of a whole set.
//!
//! Over any `embedded-storage` [`NorFlash`]: the board's flash
//! (`firmware::board::flash`), a host file in QEMU, a RAM model in tests.
//!
//! A word whose programming or erasing the power cut can read back as
//! an error rather than as bytes: the G474's flash keeps an ECC per
//! double word and raises a double-error detection on a torn one
//! (RM0440 3.3.4). Such a read ([`Corruption::corrupt`]) makes its slot
//! not valid, as a CRC mismatch does; any other flash error stays an
//! error.

use crate::stored::{Refused, Stored, MAX_BYTES};
use embedded_storage::nor_flash::NorFlash;

/// "SKN1": a slot header.
const MAGIC: u32 = 0x534B_4E31;

/// A slot's header, bytes: magic, generation, body length, body CRC,
/// header CRC, padding; a multiple of any write size up to 32 bytes.
pub const HEADER: usize = 32;

/// Whether a flash error says the bytes read cannot be trusted (a torn
/// word's ECC failed), not that the flash failed.
pub trait Corruption {
    /// The bytes read are corrupt.
    fn corrupt(&self) -> bool;
}

/// Why the store could not do what was asked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreError<E> {
    /// The flash reported an error (the set in force is unchanged).
    Flash(E),
    /// The set breaks a rule (nothing was written).
    Refused(Refused),
    /// The slots do not fit the flash's pages and words.
    Layout(&'static str),
    /// What was written does not read back (the set in force is
    /// unchanged).
    Verify,
    /// A staged set's bytes do not have the CRC its commit gives
    /// (nothing put in force).
    Mismatch,
    /// A staged set's bytes are not a set (nothing put in force).
    Malformed,
}

/// The largest flash word a store writes through, bytes (a header is
/// whole words of any size up to its own).
const WORD_MAX: usize = HEADER;

/// A set being written into the slot not in force as its pieces come
/// ([`Store::begin`], [`Store::append`], [`Store::commit`]): a device
/// stages an upload in flash, not in 2 KiB of RAM.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Staged {
    /// The slot written (not the one in force).
    slot: usize,
    /// Body bytes received.
    len: usize,
    /// The bytes received past the last whole flash word: written with
    /// the word they complete (or, padded, at the commit).
    tail: [u8; WORD_MAX],
}

impl Staged {
    /// Body bytes received so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing received yet.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A slot's header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    generation: u32,
    len: u32,
    body_crc: u32,
}

impl Header {
    fn to_bytes(self) -> [u8; HEADER] {
        let mut b = [0xFF; HEADER];
        b[0..4].copy_from_slice(&MAGIC.to_le_bytes());
        b[4..8].copy_from_slice(&self.generation.to_le_bytes());
        b[8..12].copy_from_slice(&self.len.to_le_bytes());
        b[12..16].copy_from_slice(&self.body_crc.to_le_bytes());
        let crc = link::CRC.checksum(&b[0..16]);
        b[16..20].copy_from_slice(&crc.to_le_bytes());
        b
    }

    fn from_bytes(b: &[u8; HEADER]) -> Option<Self> {
        let word = |k: usize| u32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
        if word(0) != MAGIC || word(16) != link::CRC.checksum(&b[0..16]) {
            return None;
        }
        let h = Self {
            generation: word(4),
            len: word(8),
            body_crc: word(12),
        };
        (h.len as usize <= MAX_BYTES).then_some(h)
    }
}

impl Header {
    /// Why header bytes `b` are not a valid header.
    fn fault(b: &[u8; HEADER]) -> SlotState {
        let word = |k: usize| u32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
        if b.iter().all(|&x| x == 0xFF) {
            SlotState::Erased
        } else if word(0) != MAGIC {
            SlotState::NoMagic
        } else if word(16) != link::CRC.checksum(&b[0..16]) {
            SlotState::HeaderCrc
        } else {
            SlotState::TooLong
        }
    }
}

/// What a slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotState {
    /// A whole valid set of this generation.
    Valid(u32),
    /// Nothing: its header is erased (never written, or an update cut
    /// before its header, which is written last).
    Erased,
    /// Its header does not start with the magic number.
    NoMagic,
    /// Its header's CRC does not match.
    HeaderCrc,
    /// Its header gives a body longer than any set.
    TooLong,
    /// Its body's CRC does not match its header's.
    BodyCrc,
    /// Its body's CRC matches, but the bytes are no set of this layout,
    /// or one that breaks the rules.
    NotASet,
    /// The flash reports its bytes corrupt (ECC).
    Unreadable,
}

impl SlotState {
    /// Whether it holds something that is not a set: spoiled (a flipped
    /// bit, a bad write), not merely empty.
    pub fn spoiled(self) -> bool {
        !matches!(self, SlotState::Valid(_) | SlotState::Erased)
    }

    /// What it holds, in words.
    pub fn describe(self) -> &'static str {
        match self {
            SlotState::Valid(_) => "a valid set",
            SlotState::Erased => "nothing (erased)",
            SlotState::NoMagic => "a header without the magic number (not a settings slot, or spoiled)",
            SlotState::HeaderCrc => "a header whose CRC does not match (a flipped bit, or a spoiled write)",
            SlotState::TooLong => "a header that gives a body longer than any set",
            SlotState::BodyCrc => {
                "a body whose CRC does not match its header's (a flipped bit, or a spoiled write)"
            }
            SlotState::NotASet => {
                "a body with a matching CRC that is no set of this layout, or breaks its rules"
            }
            SlotState::Unreadable => "bytes the flash reports corrupt (ECC)",
        }
    }
}

/// `a` is a later generation than `b` (wrapping).
fn newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// The set in force and its generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The set.
    pub set: Stored,
    /// Its generation (one more for each update).
    pub generation: u32,
    /// Its slot (0 or 1).
    pub slot: usize,
}

/// The two slots on a flash.
pub struct Store<F> {
    flash: F,
    base: u32,
    slot_bytes: u32,
}

impl<F: NorFlash> Store<F>
where
    F::Error: Corruption,
{
    /// Two slots of `slot_bytes` each from `base` on `flash`: both whole
    /// erase pages, large enough for a header and the longest set.
    pub fn new(flash: F, base: u32, slot_bytes: u32) -> Result<Self, StoreError<F::Error>> {
        let page = F::ERASE_SIZE as u32;
        if base % page != 0 || slot_bytes % page != 0 {
            return Err(StoreError::Layout("the slots must be whole erase pages"));
        }
        if (slot_bytes as usize) < HEADER + MAX_BYTES
            || HEADER % F::WRITE_SIZE != 0
            || F::WRITE_SIZE > WORD_MAX
        {
            return Err(StoreError::Layout(
                "a slot must hold a header and the longest set",
            ));
        }
        if u64::from(base) + 2 * u64::from(slot_bytes) > flash.capacity() as u64 {
            return Err(StoreError::Layout("the slots must lie within the flash"));
        }
        Ok(Self {
            flash,
            base,
            slot_bytes,
        })
    }

    /// The flash back.
    pub fn release(self) -> F {
        self.flash
    }

    fn slot_at(&self, slot: usize) -> u32 {
        self.base + slot as u32 * self.slot_bytes
    }

    /// Slot `slot`'s header, if the slot holds a whole valid set: the set
    /// then in `out` (otherwise `out` is anything).
    fn read_slot(&mut self, slot: usize, out: &mut Stored) -> Result<Option<Header>, F::Error> {
        Ok(self.examine(slot, out)?.ok())
    }

    /// Slot `slot`'s header where it holds a whole valid set (the set
    /// then in `out`), else what it holds instead.
    fn examine(&mut self, slot: usize, out: &mut Stored) -> Result<Result<Header, SlotState>, F::Error> {
        let at = self.slot_at(slot);
        let mut h = [0u8; HEADER];
        match self.flash.read(at, &mut h) {
            Err(e) if e.corrupt() => return Ok(Err(SlotState::Unreadable)),
            other => other?,
        }
        let Some(header) = Header::from_bytes(&h) else {
            return Ok(Err(Header::fault(&h)));
        };
        let mut body = [0u8; MAX_BYTES];
        let body = &mut body[..header.len as usize];
        match self.flash.read(at + HEADER as u32, body) {
            Err(e) if e.corrupt() => return Ok(Err(SlotState::Unreadable)),
            other => other?,
        }
        if link::CRC.checksum(body) != header.body_crc {
            return Ok(Err(SlotState::BodyCrc));
        }
        match out.read_from(body) {
            true => Ok(Ok(header)),
            false => Ok(Err(SlotState::NotASet)),
        }
    }

    /// What each slot holds (the host's report of a flash image: which
    /// slot is spoiled, and how).
    pub fn inspect(&mut self) -> Result<[SlotState; 2], F::Error> {
        let mut scratch = Stored::uncalibrated();
        let mut state = |slot| -> Result<SlotState, F::Error> {
            Ok(match self.examine(slot, &mut scratch)? {
                Ok(h) => SlotState::Valid(h.generation),
                Err(s) => s,
            })
        };
        Ok([state(0)?, state(1)?])
    }

    /// Slot `slot`'s header, if the slot holds a whole valid set. Its own
    /// frame: the set it parses (1.8 KiB) is not kept on the caller's
    /// stack.
    #[inline(never)]
    fn valid_header(&mut self, slot: usize) -> Result<Option<Header>, F::Error> {
        let mut scratch = Stored::uncalibrated();
        self.read_slot(slot, &mut scratch)
    }

    /// The slot in force and its generation: the valid slot of the newer
    /// generation; None if neither slot holds a valid set.
    fn current(&mut self) -> Result<Option<(usize, u32)>, F::Error> {
        let a = self.valid_header(0)?;
        let b = self.valid_header(1)?;
        Ok(match (a, b) {
            (Some(a), Some(b)) if newer(b.generation, a.generation) => Some((1, b.generation)),
            (Some(a), _) => Some((0, a.generation)),
            (None, Some(b)) => Some((1, b.generation)),
            (None, None) => None,
        })
    }

    /// The set in force: the valid slot of the newer generation; None if
    /// neither slot holds a valid set (a new device).
    pub fn load(&mut self) -> Result<Option<Loaded>, StoreError<F::Error>> {
        let Some((slot, _)) = self.current().map_err(StoreError::Flash)? else {
            return Ok(None);
        };
        let mut set = Stored::uncalibrated();
        Ok(self
            .read_slot(slot, &mut set)
            .map_err(StoreError::Flash)?
            .map(|h| Loaded {
                set,
                generation: h.generation,
                slot,
            }))
    }

    /// Check `set` and make it the set in force (in the slot not in
    /// force); its generation. On any error the set in force is
    /// unchanged.
    pub fn save(&mut self, set: &Stored) -> Result<u32, StoreError<F::Error>> {
        set.check().map_err(StoreError::Refused)?;
        let mut body = [0u8; MAX_BYTES];
        let bytes = set
            .to_bytes(&mut body)
            .ok_or(StoreError::Layout("the set is longer than a slot holds"))?;
        let crc = link::CRC.checksum(bytes);
        let mut staged = self.begin()?;
        self.append(&mut staged, bytes)?;
        match self.commit(staged, crc) {
            // The bytes were ours: the flash did not keep them.
            Err(StoreError::Mismatch | StoreError::Malformed) => Err(StoreError::Verify),
            other => other,
        }
    }

    /// Begin a new set in the slot not in force: erased, ready for
    /// [`Store::append`]. The set in force is untouched until
    /// [`Store::commit`].
    pub fn begin(&mut self) -> Result<Staged, StoreError<F::Error>> {
        let slot = match self.current().map_err(StoreError::Flash)? {
            Some((slot, _)) => 1 - slot,
            None => 0,
        };
        let at = self.slot_at(slot);
        self.flash
            .erase(at, at + self.slot_bytes)
            .map_err(StoreError::Flash)?;
        Ok(Staged {
            slot,
            len: 0,
            tail: [0xFF; WORD_MAX],
        })
    }

    /// The next bytes of the staged set, written through whole flash
    /// words (a last partial word waits in the tail).
    pub fn append(&mut self, staged: &mut Staged, data: &[u8]) -> Result<(), StoreError<F::Error>> {
        if staged.len + data.len() > MAX_BYTES {
            return Err(StoreError::Layout("the set is longer than a slot holds"));
        }
        let w = F::WRITE_SIZE;
        let body = self.slot_at(staged.slot) + HEADER as u32;
        let mut data = data;
        while !data.is_empty() {
            let fill = staged.len % w;
            let n = if fill == 0 && data.len() >= w {
                // Whole words straight from the piece.
                let n = data.len() / w * w;
                self.flash
                    .write(body + staged.len as u32, &data[..n])
                    .map_err(StoreError::Flash)?;
                n
            } else {
                let n = (w - fill).min(data.len());
                staged.tail[fill..fill + n].copy_from_slice(&data[..n]);
                if fill + n == w {
                    self.flash
                        .write(body + (staged.len - fill) as u32, &staged.tail[..w])
                        .map_err(StoreError::Flash)?;
                }
                n
            };
            staged.len += n;
            data = &data[n..];
        }
        Ok(())
    }

    /// Put the staged set in force if its bytes have CRC-32 `crc` and
    /// are a set that keeps every rule: its header written last, a
    /// generation above the one in force, read back; the new generation.
    /// On any error the set in force is unchanged.
    pub fn commit(&mut self, mut staged: Staged, crc: u32) -> Result<u32, StoreError<F::Error>> {
        let (w, len) = (F::WRITE_SIZE, staged.len);
        let at = self.slot_at(staged.slot);
        let fill = len % w;
        if fill != 0 {
            // The last word, padded as erased.
            staged.tail[fill..w].fill(0xFF);
            self.flash
                .write(at + (HEADER + len - fill) as u32, &staged.tail[..w])
                .map_err(StoreError::Flash)?;
        }
        let generation = match self.current().map_err(StoreError::Flash)? {
            // The slot in force is never written: not a set staged here.
            Some((slot, _)) if slot == staged.slot => return Err(StoreError::Verify),
            Some((_, generation)) => generation.wrapping_add(1),
            None => 1,
        };
        self.check_staged(at, len, crc)?;
        let header = Header {
            generation,
            len: len as u32,
            body_crc: crc,
        };
        self.flash
            .write(at, &header.to_bytes())
            .map_err(StoreError::Flash)?;
        if !self.header_reads_back(at, header).map_err(StoreError::Flash)? {
            // Not what was written: take the slot out of the running
            // (an erased slot is not valid), the set in force stays.
            self.flash
                .erase(at, at + self.slot_bytes)
                .map_err(StoreError::Flash)?;
            return Err(StoreError::Verify);
        }
        Ok(generation)
    }

    /// The header at `at` reads back as `header` (the body behind it was
    /// read back whole by [`Store::check_staged`] before it was written).
    fn header_reads_back(&mut self, at: u32, header: Header) -> Result<bool, F::Error> {
        let mut h = [0u8; HEADER];
        match self.flash.read(at, &mut h) {
            Err(e) if e.corrupt() => return Ok(false),
            other => other?,
        }
        Ok(Header::from_bytes(&h) == Some(header))
    }

    /// The `len` staged bytes after the header at `at` have CRC `crc`
    /// and are a set that keeps every rule. Its own frame: the body and
    /// the set it parses (3.8 KiB) are not kept on the caller's stack.
    #[inline(never)]
    fn check_staged(&mut self, at: u32, len: usize, crc: u32) -> Result<(), StoreError<F::Error>> {
        let mut body = [0u8; MAX_BYTES];
        let body = &mut body[..len];
        match self.flash.read(at + HEADER as u32, body) {
            Err(e) if e.corrupt() => return Err(StoreError::Mismatch),
            other => other.map_err(StoreError::Flash)?,
        }
        if link::CRC.checksum(body) != crc {
            return Err(StoreError::Mismatch);
        }
        match Stored::from_bytes(body) {
            None => Err(StoreError::Malformed),
            Some(Err(r)) => Err(StoreError::Refused(r)),
            Some(Ok(_)) => Ok(()),
        }
    }
}

/// NOR flash in a byte buffer, with the board's units (8-byte words,
/// 4 KiB erase units) and NOR's rule (a word is programmed only where it
/// is erased): a flash image on the host (QEMU's settings file, a tool
/// preparing one).
pub struct RamFlash<'a> {
    mem: &'a mut [u8],
}

/// Why a [`RamFlash`] operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    /// Outside the buffer, or not aligned.
    Bounds,
    /// A word programmed that was not erased.
    NotErased,
}

/// A RAM image has no ECC: its bytes are what they are.
impl Corruption for RamFlashError {
    fn corrupt(&self) -> bool {
        false
    }
}

impl embedded_storage::nor_flash::NorFlashError for RamFlashError {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        use embedded_storage::nor_flash::NorFlashErrorKind;
        match self {
            RamFlashError::Bounds => NorFlashErrorKind::OutOfBounds,
            RamFlashError::NotErased => NorFlashErrorKind::Other,
        }
    }
}

impl<'a> RamFlash<'a> {
    /// Over `mem` (its length a multiple of 4 KiB; all 0xFF is erased).
    pub fn new(mem: &'a mut [u8]) -> Self {
        Self { mem }
    }
}

impl embedded_storage::nor_flash::ErrorType for RamFlash<'_> {
    type Error = RamFlashError;
}

impl embedded_storage::nor_flash::ReadNorFlash for RamFlash<'_> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamFlashError> {
        let at = offset as usize;
        let src = self.mem.get(at..at + bytes.len()).ok_or(RamFlashError::Bounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for RamFlash<'_> {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = 4096;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamFlashError> {
        let (from, to) = (from as usize, to as usize);
        if from % Self::ERASE_SIZE != 0 || to % Self::ERASE_SIZE != 0 || from > to || to > self.mem.len() {
            return Err(RamFlashError::Bounds);
        }
        self.mem[from..to].fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamFlashError> {
        let at = offset as usize;
        if at % Self::WRITE_SIZE != 0
            || bytes.len() % Self::WRITE_SIZE != 0
            || at + bytes.len() > self.mem.len()
        {
            return Err(RamFlashError::Bounds);
        }
        let dst = &mut self.mem[at..at + bytes.len()];
        if dst.iter().any(|&b| b != 0xFF) {
            return Err(RamFlashError::NotErased);
        }
        dst.copy_from_slice(bytes);
        Ok(())
    }
}

/// The settings' region on every image: two slots of 4 KiB.
pub const REGION_BYTES: usize = 8192;
/// A slot, bytes.
pub const SLOT_BYTES: u32 = 4096;

#[cfg(test)]
mod tests;
