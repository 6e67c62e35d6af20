//! The record link: what leaves the device, defined once for the
//! firmware and the host.
//!
//! A stream is a start frame, record frames (with a status frame once a
//! second) and an end frame. Each frame
//! is its [`Body`] with a sequence number, encoded with postcard, followed
//! by the CRC-32 (ISO-HDLC) of those bytes, little-endian; the whole is
//! COBS-encoded and ends with a zero byte, so that a receiver that joins
//! late, or loses bytes, finds the next frame at the next zero.
//!
//! A receiver ([`Decoder`]) hands back every frame whose CRC holds and
//! counts the rest; the sequence numbers tell it how many frames it
//! lost. A record it hands back is one the device sent: a corrupted frame
//! passes the CRC with a probability of 2⁻³².
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

use serde::{Deserialize, Serialize};

/// The version of this wire format, sent in every [`Start`] frame. A
/// receiver refuses a stream of another version.
pub const VERSION: u16 = 5;

/// The board link's baud rate: LPUART1 of the STM32G474 into the
/// Nucleo-G474RE's STLINK-V3E, whose virtual COM port carries it to the
/// host over USB. ST gives the STLINK-V3's virtual COM port "up to 15 MHz"
/// (`docs/firmware.md` cites the page); LPUART1 at 170 MHz makes it
/// within 0.02 % (its divider is 256 · 170 MHz / 15 MBd = 2901.3).
pub const BOARD_BAUD: u32 = 15_000_000;

/// Bits on the wire per byte: 8 data bits, no parity, a start and a stop
/// bit (8N1).
pub const BITS_PER_BYTE: u32 = 10;

/// The most records a second the link is sized for: 16 sensors × 1000
/// records/s, at most [`LOAD_LIMIT`] of [`BOARD_BAUD`] with every frame as
/// long as a record's frame can be ([`longest_record_frame`]).
pub const RECORDS_PER_S: u32 = 16 * 1000;

/// The share of the baud rate the records may take, percent.
pub const LOAD_LIMIT: u32 = 80;

/// The longest a record's frame can be on the wire, bytes: every varint
/// at its longest that a year's run can reach (sequence number `u32::MAX`,
/// a time of a year in µs, every flag set).
pub fn longest_record_frame() -> usize {
    let worst = Record {
        t_us: 366 * 86_400 * 1_000_000,
        sensor: u8::MAX,
        tones: [Tone {
            f_hz: 1.0e5,
            z_re_ohm: 1.0e6,
            z_im_ohm: -1.0e7,
        }; 2],
        c_farad: 1.0e-9,
        r_ohm: 1.0e6,
        stretch_mm: 10.0,
        chosen_hz: 1.0e4,
        chi2: 100.0,
        sigma_ln_c: 1.0,
        flags: u16::MAX,
    };
    let frame = Frame {
        seq: u32::MAX,
        body: Body::Record(worst),
    };
    let mut out = [0u8; MAX_FRAME];
    encode(&frame, &mut out).map_or(MAX_FRAME, <[u8]>::len)
}

/// The longest frame on the wire, bytes: the longest body, its CRC, the
/// COBS overhead and the closing zero.
pub const MAX_FRAME: usize = 96;

/// The longest body before the CRC and COBS, bytes.
const MAX_BODY: usize = MAX_FRAME - 4 - 2 - 1;

/// The table of [`CRC`]: 1 KiB, a byte at a time (the firmware's); with
/// the `fast-crc` feature 16 KiB, sixteen bytes at a time (the host's
/// decoder, which replays streams of 10⁶ records a second); with
/// `small-crc` none, a bit at a time (the single-channel board with its
/// store). The same CRC whichever.
#[cfg(not(any(feature = "fast-crc", feature = "small-crc")))]
pub type CrcTable = crc::Table<1>;
/// The table of [`CRC`] (see the other definition).
#[cfg(all(feature = "small-crc", not(feature = "fast-crc")))]
pub type CrcTable = crc::NoTable;
/// The table of [`CRC`] (see the other definition).
#[cfg(feature = "fast-crc")]
pub type CrcTable = crc::Table<16>;

/// The CRC of a frame, CRC-32/ISO-HDLC (Ethernet's, zlib's); the one
/// table every CRC-32 of an image uses (the stored settings and their
/// digest too: one table in flash, not one per user).
pub static CRC: crc::Crc<u32, CrcTable> = crc::Crc::<u32, CrcTable>::new(&crc::CRC_32_ISO_HDLC);

/// One tone's measurement: its frequency and the sensor's impedance there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tone {
    /// Frequency, Hz.
    pub f_hz: f32,
    /// Re Z, Ω.
    pub z_re_ohm: f32,
    /// Im Z, Ω.
    pub z_im_ohm: f32,
}

/// One record: a sensor's block, its tones, the line, the stretch and the
/// flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Middle of the block since start, µs.
    pub t_us: u64,
    /// Sensor.
    pub sensor: u8,
    /// The tones measured (one for the multiplexed firmware, two for the
    /// array), lower first; the rest are zero.
    pub tones: [Tone; 2],
    /// Line capacitance, F (0: no line).
    pub c_farad: f32,
    /// Line resistance (both electrodes), Ω (0: no line).
    pub r_ohm: f32,
    /// Stretch from the sensor's calibration, mm.
    pub stretch_mm: f32,
    /// The frequency the policy chose for the sensor's next block, Hz.
    pub chosen_hz: f32,
    /// χ² of the record's line (0 for one tone; the array fits its pair
    /// and the tone between them: 4 degrees of freedom).
    pub chi2: f32,
    /// 1σ relative error of C (0: not stated).
    pub sigma_ln_c: f32,
    /// Flags (`instrument::faults::Flags`), 0 = valid.
    pub flags: u16,
}

impl Record {
    /// The tones measured: those with a frequency.
    pub fn measured(&self) -> impl Iterator<Item = &Tone> {
        self.tones.iter().filter(|t| t.f_hz > 0.0)
    }
}

/// The first frame of a stream: what produced it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Start {
    /// The wire format's version ([`VERSION`]).
    pub version: u16,
    /// The firmware's name and version, ASCII, padded with zeros.
    pub firmware: [u8; 24],
    /// A digest of the settings in force.
    pub settings_digest: u32,
    /// A digest of the calibrations in force.
    pub calibration_digest: u32,
    /// Sensors read.
    pub sensors: u8,
    /// The ADC's sample rate, Hz.
    pub sample_rate_hz: u32,
    /// The generation of the stored set in force (0: none stored, the
    /// firmware's own set).
    pub generation: u32,
    /// The device's id (a board's: the CRC-32 of its chip's unique ID;
    /// QEMU's: its `device=` argument, 0 without), which tells the boards
    /// of a skin apart.
    pub device_id: u32,
    /// The power-up self-test's result (the array's reference network,
    /// measured before the skin).
    pub self_test: SelfTest,
}

/// What the power-up self-test found, as the start frame carries it
/// (`instrument::selftest`). A path is an ADC input: bit 0 the
/// excitation, bits 1–16 the sensors' stages, bit 17 the reference
/// network's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SelfTest {
    /// What became of it.
    pub verdict: Verdict,
    /// Paths that failed a check (on a rail, offset, the excitation's
    /// amplitude, the reference's impedance): the records resting on
    /// one are flagged `SELF_TEST`.
    pub failed: u32,
    /// Paths whose noise exceeded its bound (reported only: each
    /// record's own residual check stands).
    pub noisy: u32,
    /// The reference network's impedance against the parts' nominal
    /// one: the worst tone's |Z| error, ppm.
    pub gain_ppm: i32,
    /// ... and its worst phase error, µrad.
    pub phase_urad: i32,
    /// The excitation's worst tone amplitude against the design, ppm.
    pub excitation_ppm: i32,
    /// The noisiest path's residual over the converter's noise, ‰.
    pub noise_permille: u16,
}

impl SelfTest {
    /// The reference network's path (bit 17 of a path mask).
    pub const REFERENCE_PATH: u32 = 17;

    /// Does it refuse sensor `sensor`'s records? Every sensor's if the
    /// excitation's path (bit 0) or the reference's failed, else those
    /// whose own stage (bit `sensor` + 1) did.
    pub fn refuses(&self, sensor: u8) -> bool {
        let chain = self.failed & (1 | 1 << Self::REFERENCE_PATH) != 0;
        chain || self.failed >> (u32::from(sensor) + 1) & 1 != 0
    }
}

/// A self-test's verdict.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Verdict {
    /// Not run: a front end without a reference network (the
    /// multiplexed board's).
    #[default]
    NotRun,
    /// Every path passed.
    Passed,
    /// A path failed ([`SelfTest::failed`]).
    Failed,
}

impl Start {
    /// The firmware's name and version as text.
    pub fn firmware_str(&self) -> &str {
        let n = self
            .firmware
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(self.firmware.len());
        core::str::from_utf8(&self.firmware[..n]).unwrap_or("?")
    }

    /// `text` as the firmware field (cut to its length).
    pub fn firmware_field(text: &str) -> [u8; 24] {
        let mut f = [0u8; 24];
        for (d, s) in f.iter_mut().zip(text.bytes()) {
            *d = s;
        }
        f
    }
}

/// The last frame of a stream that ended as it should.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct End {
    /// Records sent.
    pub records: u32,
    /// Records dropped before they were sent (the device's queue was
    /// full).
    pub dropped: u32,
}

/// A new set in force, sent when the device applies one while it runs
/// (a set written down the link): every record after this frame was
/// measured with it, every record before with the one in force before.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Applied {
    /// The set's generation in the device's store.
    pub generation: u32,
    /// A digest of the settings now in force (as a [`Start`]'s).
    pub settings_digest: u32,
    /// A digest of the calibrations now in force (as a [`Start`]'s).
    pub calibration_digest: u32,
    /// A device time, µs (as a record's), between the records of the two
    /// sets: every record before this frame is at or before it, every
    /// record after it later.
    pub t_us: u64,
}

/// What a [`Status`] frame's times count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Clock {
    /// The core's clock cycles (the board's DWT cycle counter).
    #[default]
    Cycles,
    /// Instructions retired (QEMU, whose `-icount` clock counts them).
    Instructions,
}

/// How the device's CPU keeps up with its blocks, sent about once a
/// second: the time from the end of a block's acquisition to its last
/// record queued for the link, in units of `clock` at `clock_hz`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// The device's time at the last block counted, µs (as a record's).
    pub t_us: u64,
    /// What the times count.
    pub clock: Clock,
    /// Their rate, Hz (the board's core: 170 MHz).
    pub clock_hz: u32,
    /// A block's period.
    pub period: u32,
    /// Blocks processed since the last status.
    pub blocks: u32,
    /// Their mean time.
    pub mean: u32,
    /// The longest.
    pub max: u32,
    /// Of those, blocks that took longer than their period: their samples
    /// may have been overwritten by the next block's, their records are
    /// flagged `LATE`.
    pub late: u32,
    /// Blocks never processed: the next had arrived while the processing
    /// of one was still due (no records).
    pub missed: u32,
}

/// Bytes of a stored set in one frame.
pub const CHUNK: usize = 32;

/// A piece of a stored set's bytes (`instrument::stored::Stored`,
/// postcard): `len` bytes of `bytes` at `offset`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Chunk {
    /// Where the piece starts in the set's bytes.
    pub offset: u16,
    /// Bytes used of `bytes`.
    pub len: u8,
    /// The bytes (the rest zero).
    #[serde(with = "chunk_bytes")]
    pub bytes: [u8; CHUNK],
}

/// [`Chunk::bytes`] on the wire as serde's derive puts an array (a tuple
/// of [`CHUNK`] elements, each byte as itself in postcard), written and
/// read by a loop: the derive's reader unrolls its 32 elements, 1 KiB of
/// code in every image that takes requests.
mod chunk_bytes {
    use super::CHUNK;
    use serde::de::{self, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer>(bytes: &[u8; CHUNK], s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(CHUNK)?;
        for b in bytes {
            t.serialize_element(b)?;
        }
        t.end()
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[u8; CHUNK], D::Error> {
        struct Bytes;
        impl<'de> Visitor<'de> for Bytes {
            type Value = [u8; CHUNK];
            fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
                f.write_str("a chunk's bytes")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = [0u8; CHUNK];
                for (k, b) in out.iter_mut().enumerate() {
                    *b = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(k, &self))?;
                }
                Ok(out)
            }
        }
        d.deserialize_tuple(CHUNK, Bytes)
    }
}

impl Chunk {
    /// The bytes used.
    pub fn data(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len).min(CHUNK)]
    }
}

/// What the host asks of the device, down the same link as the records
/// come up. The device answers each with a [`Reply`] naming its sequence
/// number.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// Send the stored set ([`Reply::Chunk`]s, then an [`Reply::Ack`];
    /// refused as [`Reason::NothingStored`] on a new device).
    ReadSettings,
    /// The next piece of a new set, in order from offset 0.
    WriteChunk(Chunk),
    /// The new set is whole: `len` bytes whose CRC-32 is `crc`. Check it
    /// and store it; the set in force is kept if anything is wrong.
    Commit {
        /// The set's length, bytes.
        len: u16,
        /// CRC-32/ISO-HDLC of its bytes.
        crc: u32,
    },
    /// Start measuring.
    Start,
    /// Stop measuring (the stream's end frame follows).
    Stop,
    /// A calibration step: for the next `4 × blocks_per_pair` blocks each
    /// sensor's records step through every tone pair the device has, a
    /// sweep of frequencies for the hold under way; then the tone policy
    /// again (1 … [`SWEEP_MAX_BLOCKS`] blocks per pair; refused by a
    /// device without tone pairs).
    Sweep {
        /// Blocks measured at each pair.
        blocks_per_pair: u16,
    },
}

/// The most blocks per pair a [`Request::Sweep`] takes (4 s at 250
/// blocks/s).
pub const SWEEP_MAX_BLOCKS: u16 = 1000;

/// Why the device refused a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reason {
    /// A piece that does not follow the last one.
    OutOfOrder,
    /// More bytes than a set can have.
    TooLong,
    /// The length or CRC of the pieces received does not match the commit.
    Mismatch,
    /// The bytes are not a set of this firmware's layout.
    Malformed,
    /// The set breaks a rule: `rule` is `instrument::stored::Rule`'s code,
    /// `sensor` the sensor (255: not a sensor's setting).
    Setting {
        /// The sensor, or 255.
        sensor: u8,
        /// The rule's code.
        rule: u8,
    },
    /// The flash failed; the set in force is unchanged.
    Flash,
    /// No set is stored (a new device).
    NothingStored,
    /// A value outside the request's range.
    OutOfRange,
    /// This device does not do what was asked (a sweep on a device of
    /// one tone).
    Unsupported,
}

/// The device's answer to the request of sequence number `to`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    /// Done as asked; for a commit, the new set's generation.
    Ack {
        /// The request's sequence number.
        to: u32,
        /// The stored set's generation after a commit (0 otherwise).
        generation: u32,
    },
    /// Refused, and why; nothing changed.
    Refused {
        /// The request's sequence number.
        to: u32,
        /// Why.
        reason: Reason,
    },
    /// A piece of the stored set, answering [`Request::ReadSettings`].
    Chunk {
        /// The request's sequence number.
        to: u32,
        /// The piece.
        chunk: Chunk,
    },
}

/// What a frame carries.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Body {
    /// The start of a stream.
    Start(Start),
    /// A record.
    Record(Record),
    /// The end of a stream.
    End(End),
    /// A request from the host.
    Request(Request),
    /// The device's reply.
    Reply(Reply),
    /// How the device's CPU keeps up.
    Status(Status),
    /// A new set in force from here on.
    Applied(Applied),
}

/// One frame: a body and its sequence number (0 for the start frame,
/// then one more for each frame).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Sequence number.
    pub seq: u32,
    /// What it carries.
    pub body: Body,
}

/// Why a frame could not be encoded or decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The output buffer is shorter than the frame.
    BufferTooSmall,
    /// More bytes than a frame can have before the closing zero.
    TooLong,
    /// Not COBS.
    Cobs,
    /// Too short to hold a CRC.
    TooShort,
    /// The CRC does not hold: the bytes changed on the way.
    Crc,
    /// The CRC holds but the body is not one this version knows (an
    /// unknown frame type, or a newer version's layout).
    Body,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Error::BufferTooSmall => "the output buffer is too small for the frame",
            Error::TooLong => "more bytes than a frame can have before its end",
            Error::Cobs => "not a COBS frame",
            Error::TooShort => "too short to be a frame",
            Error::Crc => "the CRC does not match: the frame was corrupted",
            Error::Body => "an unknown frame type or layout",
        })
    }
}

impl core::error::Error for Error {}

/// Encode `frame` into `out`: the bytes to send, closing zero included.
pub fn encode<'a>(frame: &Frame, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
    seal(frame, out)
}

/// `value`'s postcard bytes, its CRC, COBS and the closing zero, into
/// `out`: the body is serialised straight into `out` after a free byte,
/// its CRC appended and the whole stuffed in place, in one pass
/// ([`checksum_and_stuff`]).
fn seal<'a, T: Serialize>(value: &T, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
    // out: [COBS code][body: n][CRC: 4][closing zero].
    let room = out.len().saturating_sub(1 + 4 + 1).min(MAX_BODY);
    let buf = out.get_mut(1..1 + room).ok_or(Error::BufferTooSmall)?;
    let n =
        postcard::serialize_with_flavor(value, Cursor { buf, n: 0 }).map_err(|_| Error::BufferTooSmall)?;
    let frame = out.get_mut(..6 + n).ok_or(Error::BufferTooSmall)?;
    checksum_and_stuff(frame);
    Ok(frame)
}

/// The CRC and the COBS of a frame in one pass: `frame` is
/// [free][body][4 free][free], fewer than 256 bytes (one COBS block,
/// which every frame is). The body's CRC ([`CRC`], from its byte table)
/// goes into the four bytes after it, little-endian; every byte is
/// stuffed as it passes: a zero takes the distance to the next zero
/// (or to the end), the free first byte the distance to the first; the
/// last byte becomes the closing zero. The same bytes as `crc`'s
/// checksum then `cobs::encode` (tested against both at every length
/// a body can have).
///
/// The body goes four bytes a turn: one load, four table steps from the
/// register, and a mask of the zero bytes among the four (the bytes are
/// not looked at one by one). About 7 instructions a byte on the
/// Cortex-M4, a zero byte's code included, where the CRC then the
/// stuffing took 12 (and the `cobs` crate's encoder, which copies, 14
/// for the stuffing alone).
fn checksum_and_stuff(frame: &mut [u8]) {
    let Some(body_end) = frame.len().checked_sub(5) else {
        return;
    };
    // One byte's step of the reflected CRC: the table's entry, or the
    // entry's eight bit steps where the image keeps no table.
    #[cfg(not(all(feature = "small-crc", not(feature = "fast-crc"))))]
    let step = {
        // The table's own address in a register (not the CRC's, four
        // bytes before it, which costs an add a byte).
        let table: &[u32; 256] = core::hint::black_box(&CRC.table()[0]);
        move |c: u32| table[(c & 0xff) as usize] ^ (c >> 8)
    };
    #[cfg(all(feature = "small-crc", not(feature = "fast-crc")))]
    let step = |mut c: u32| {
        for _ in 0..8 {
            c = (c >> 1) ^ (0xEDB8_8320 & (c & 1).wrapping_neg());
        }
        c
    };
    // CRC-32/ISO-HDLC, reflected: init and final xor all ones.
    let mut crc = !0u32;
    // The byte whose code is pending: the first, then the last zero.
    let mut code = 0;
    let mut zero_at = |frame: &mut [u8], i: usize| {
        if let Some(c) = frame.get_mut(code) {
            *c = (i - code) as u8;
        }
        code = i;
    };
    let mut i = 1;
    while let Some(w) = frame
        .get(i..i + 4)
        .filter(|_| i + 4 <= body_end)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(u32::from_le_bytes)
    {
        crc = step(step(step(step(crc ^ w))));
        // Bit 7 of each zero byte of w, exactly (the low seven bits'
        // sum cannot carry into the next byte).
        let mut zeros = !(((w & 0x7f7f_7f7f) + 0x7f7f_7f7f) | w | 0x7f7f_7f7f);
        while zeros != 0 {
            zero_at(frame, i + (zeros.trailing_zeros() / 8) as usize);
            zeros &= zeros - 1;
        }
        i += 4;
    }
    while let Some(&b) = frame.get(i).filter(|_| i < body_end) {
        crc = step(crc ^ u32::from(b));
        if b == 0 {
            zero_at(frame, i);
        }
        i += 1;
    }
    for (j, b) in (!crc).to_le_bytes().into_iter().enumerate() {
        if let Some(slot) = frame.get_mut(body_end + j) {
            *slot = b;
        }
        if b == 0 {
            zero_at(frame, body_end + j);
        }
    }
    let end = body_end + 4;
    zero_at(frame, end);
    if let Some(last) = frame.get_mut(end) {
        *last = 0;
    }
}

/// postcard's output into a byte slice, as its `Slice` flavor, but a
/// varint's few bytes are copied in a loop, not by a `memcpy` call (about
/// fifty instructions for one to five bytes on the Cortex-M4, three times
/// a record), and a fixed four (an f32) by one word. The bytes are the
/// same: the flavor only stores them.
struct Cursor<'a> {
    buf: &'a mut [u8],
    n: usize,
}

impl postcard::ser_flavors::Flavor for Cursor<'_> {
    /// Bytes written.
    type Output = usize;

    #[inline(always)]
    fn try_push(&mut self, b: u8) -> postcard::Result<()> {
        let slot = self
            .buf
            .get_mut(self.n)
            .ok_or(postcard::Error::SerializeBufferFull)?;
        *slot = b;
        self.n += 1;
        Ok(())
    }

    #[inline(always)]
    fn try_extend(&mut self, b: &[u8]) -> postcard::Result<()> {
        if let Ok(word) = <&[u8; 4]>::try_from(b) {
            let end = self.n + 4;
            let slot = self
                .buf
                .get_mut(self.n..end)
                .ok_or(postcard::Error::SerializeBufferFull)?;
            slot.copy_from_slice(word);
            self.n = end;
            Ok(())
        } else {
            // Byte by byte, each checked: a loop that can stop early is
            // not turned into a `memcpy` call.
            b.iter().try_for_each(|&x| self.try_push(x))
        }
    }

    fn finalize(self) -> postcard::Result<usize> {
        Ok(self.n)
    }
}

/// A frame before its closing zero is one COBS block: under 254 bytes.
const _: () = assert!(1 + MAX_BODY + 4 < 255);

/// Decode one frame from its COBS bytes (without the closing zero).
pub fn decode(cobs_bytes: &[u8]) -> Result<Frame, Error> {
    let mut raw = [0u8; MAX_FRAME];
    match postcard::take_from_bytes::<Frame>(unseal(cobs_bytes, &mut raw)?) {
        Ok((frame, [])) => Ok(frame),
        _ => Err(Error::Body),
    }
}

/// [`decode`] for a device, which reads only requests: a frame's
/// sequence number, and its request if it is one (None: a frame of
/// another body, not decoded). Its image holds the deserialiser of a
/// request alone.
pub fn decode_request(cobs_bytes: &[u8]) -> Result<(u32, Option<Request>), Error> {
    /// [`Body::Request`]'s index among the bodies (postcard's tag).
    const REQUEST: u32 = 3;
    let mut raw = [0u8; MAX_FRAME];
    let body = unseal(cobs_bytes, &mut raw)?;
    let ((seq, variant), rest) = postcard::take_from_bytes::<(u32, u32)>(body).map_err(|_| Error::Body)?;
    if variant != REQUEST {
        return Ok((seq, None));
    }
    match postcard::take_from_bytes::<Request>(rest) {
        Ok((request, [])) => Ok((seq, Some(request))),
        _ => Err(Error::Body),
    }
}

/// A frame's COBS bytes undone into `raw`, its CRC checked: the body's
/// bytes.
fn unseal<'a>(cobs_bytes: &[u8], raw: &'a mut [u8; MAX_FRAME]) -> Result<&'a [u8], Error> {
    if cobs_bytes.len() > MAX_FRAME {
        return Err(Error::TooLong);
    }
    let n = cobs::decode(cobs_bytes, raw).map_err(|_| Error::Cobs)?;
    if n < 5 {
        return Err(Error::TooShort);
    }
    let (body, crc) = raw[..n].split_at(n - 4);
    let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if CRC.checksum(body) != crc {
        return Err(Error::Crc);
    }
    Ok(body)
}

/// What a [`Decoder`] has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Frames decoded.
    pub frames: u64,
    /// Frames refused (corrupted, too long, unknown).
    pub bad: u64,
    /// Frames the sequence numbers say never arrived (gaps).
    pub lost: u64,
    /// Frames received twice (a sequence number seen just before).
    pub repeated: u64,
    /// Bytes received.
    pub bytes: u64,
}

/// A receiver: bytes in, frames out, in order.
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
    next_seq: Option<u32>,
    stats: Stats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A receiver that has seen nothing.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
            next_seq: None,
            stats: Stats {
                frames: 0,
                bad: 0,
                lost: 0,
                repeated: 0,
                bytes: 0,
            },
        }
    }

    /// What it has seen so far.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Take one byte: a frame when it closes one that holds; an error
    /// when it closes one that does not (counted, and the receiver goes
    /// on at the next frame); nothing otherwise. A frame whose sequence
    /// number repeats the last one's is dropped as a duplicate.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame, Error>> {
        self.push_as(byte, decode, |f| f.seq)
    }

    /// [`Decoder::push`] for a device: a request when the byte closes a
    /// frame that holds one ([`decode_request`]); a frame of another body
    /// is counted and its sequence number followed, as `push` does, but
    /// not decoded.
    pub fn push_request(&mut self, byte: u8) -> Option<Result<(u32, Request), Error>> {
        match self.push_as(byte, decode_request, |r| r.0)? {
            Ok((seq, Some(request))) => Some(Ok((seq, request))),
            Ok((_, None)) => None,
            Err(e) => Some(Err(e)),
        }
    }

    /// One byte, a frame it closes decoded by `decode`; `seq` its
    /// sequence number.
    fn push_as<T>(
        &mut self,
        byte: u8,
        decode: impl Fn(&[u8]) -> Result<T, Error>,
        seq: impl Fn(&T) -> u32,
    ) -> Option<Result<T, Error>> {
        if byte != 0 {
            self.take(&[byte]);
            return None;
        }
        self.stats.bytes += 1;
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if len == 0 {
            // Two zeros in a row: nothing between them.
            return None;
        }
        let result = if overflow {
            Err(Error::TooLong)
        } else {
            decode(&self.buf[..len])
        };
        match result {
            Ok(frame) => self.sequence(seq(&frame)).then_some(Ok(frame)),
            Err(e) => {
                self.stats.bad += 1;
                Some(Err(e))
            }
        }
    }

    /// Take bytes from the front of `bytes` up to the next frame they
    /// close, and that frame (or why it does not hold) as
    /// [`Decoder::push`] gives it; None once `bytes` is used up (then
    /// empty). The same frames and counts as pushing the bytes one at a
    /// time (`the_bytes_at_once_are_the_bytes_one_by_one`), a frame's
    /// bytes found and copied at once.
    pub fn next_frame(&mut self, bytes: &mut &[u8]) -> Option<Result<Frame, Error>> {
        loop {
            let Some(end) = bytes.iter().position(|&b| b == 0) else {
                self.take(bytes);
                *bytes = &[];
                return None;
            };
            self.take(&bytes[..end]);
            *bytes = &bytes[end + 1..];
            if let Some(r) = self.push(0) {
                return Some(r);
            }
        }
    }

    /// Take bytes that hold no zero.
    fn take(&mut self, part: &[u8]) {
        self.stats.bytes += part.len() as u64;
        let room = self.buf.len() - self.len;
        if part.len() > room {
            self.overflow = true;
        }
        let n = part.len().min(room);
        self.buf[self.len..self.len + n].copy_from_slice(&part[..n]);
        self.len += n;
    }

    /// Account for a frame's sequence number `seq`; false for a
    /// duplicate.
    fn sequence(&mut self, seq: u32) -> bool {
        if let Some(next) = self.next_seq {
            if seq == next.wrapping_sub(1) {
                self.stats.repeated += 1;
                return false;
            }
            let gap = seq.wrapping_sub(next);
            if gap < u32::MAX / 2 {
                self.stats.lost += u64::from(gap);
            }
        }
        self.next_seq = Some(seq.wrapping_add(1));
        self.stats.frames += 1;
        true
    }
}

/// The sender's side: numbers frames and encodes them.
#[derive(Clone, Debug, Default)]
pub struct Encoder {
    seq: u32,
}

impl Encoder {
    /// A sender whose next frame is the start frame (sequence 0).
    pub const fn new() -> Self {
        Self { seq: 0 }
    }

    /// The sequence number the next frame gets.
    pub fn next_seq(&self) -> u32 {
        self.seq
    }

    /// Number and encode a body given as its variant's index in [`Body`]
    /// and its payload: the same bytes as [`Encoder::frame`] (postcard
    /// writes an enum as its variant's index, then the variant), but the
    /// image holds the serialiser of that payload only (the device sends
    /// records and replies, not requests).
    fn part<'a, T: Serialize>(
        &mut self,
        variant: u32,
        payload: &T,
        out: &'a mut [u8],
    ) -> Result<&'a [u8], Error> {
        let bytes = seal(&(self.seq, variant, payload), out)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(bytes)
    }

    /// [`Encoder::frame`] of a [`Body::Start`].
    pub fn start<'a>(&mut self, start: &Start, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(0, start, out)
    }

    /// [`Encoder::frame`] of a [`Body::Record`].
    pub fn record<'a>(&mut self, record: &Record, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(1, record, out)
    }

    /// [`Encoder::frame`] of a [`Body::End`].
    pub fn end<'a>(&mut self, end: &End, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(2, end, out)
    }

    /// [`Encoder::frame`] of a [`Body::Reply`].
    pub fn reply<'a>(&mut self, reply: &Reply, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(4, reply, out)
    }

    /// [`Encoder::frame`] of a [`Body::Status`].
    pub fn status<'a>(&mut self, status: &Status, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(5, status, out)
    }

    /// [`Encoder::frame`] of a [`Body::Applied`].
    pub fn applied<'a>(&mut self, applied: &Applied, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        self.part(6, applied, out)
    }

    /// Number `body` and encode it into `out`.
    pub fn frame<'a>(&mut self, body: Body, out: &'a mut [u8]) -> Result<&'a [u8], Error> {
        let frame = Frame { seq: self.seq, body };
        let bytes = encode(&frame, out)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use proptest::prelude::*;
    use std::{vec, vec::Vec};

    /// A chunk as serde's derive writes and reads it (its array field
    /// plain), to hold [`super::Chunk`]'s looped field to the same wire.
    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct Derived {
        offset: u16,
        len: u8,
        bytes: [u8; super::CHUNK],
    }

    proptest! {
        /// A chunk's bytes on the wire are the derive's, both ways; a
        /// piece cut short is refused by both.
        #[test]
        fn a_chunk_is_on_the_wire_as_the_derive_puts_it(
            offset: u16,
            len: u8,
            bytes in proptest::array::uniform32(any::<u8>()),
            cut in 0usize..36,
        ) {
            let chunk = super::Chunk { offset, len, bytes };
            let derived = Derived { offset, len, bytes };
            let mut a = [0u8; 64];
            let mut b = [0u8; 64];
            let a = postcard::to_slice(&chunk, &mut a).unwrap();
            let b = postcard::to_slice(&derived, &mut b).unwrap();
            prop_assert_eq!(&a[..], &b[..]);
            prop_assert_eq!(postcard::from_bytes::<super::Chunk>(b).unwrap(), chunk);
            let short = &b[..cut.min(b.len() - 1)];
            prop_assert!(postcard::from_bytes::<super::Chunk>(short).is_err());
            prop_assert!(postcard::from_bytes::<Derived>(short).is_err());
        }
    }

    /// The one-pass CRC and stuffing against the crates: the body, its
    /// `crc` CRC, `cobs::encode` of both and the closing zero; and back
    /// through `cobs::decode`.
    fn one_pass_is_the_crates(body: &[u8]) {
        let mut raw = body.to_vec();
        raw.extend_from_slice(&super::CRC.checksum(body).to_le_bytes());
        let mut want = vec![0u8; cobs::max_encoding_length(raw.len())];
        let n = cobs::encode(&raw, &mut want);
        want.truncate(n);
        want.push(0);
        let mut got = vec![0u8];
        got.extend_from_slice(body);
        got.extend_from_slice(&[0xa5; 5]);
        super::checksum_and_stuff(&mut got);
        assert_eq!(got, want, "{body:?}");
        let mut back = vec![0u8; raw.len()];
        let k = cobs::decode(&got[..got.len() - 1], &mut back).expect("decodes");
        assert_eq!(&back[..k], &raw[..]);
    }

    /// Every length a body can have: all zeros, no zeros, zeros at the
    /// ends; and a body whose CRC holds a zero byte.
    #[test]
    fn one_pass_is_the_crates_at_every_length() {
        for len in 0..=super::MAX_BODY {
            let run: Vec<u8> = (0..len).map(|i| (i % 255 + 1) as u8).collect();
            one_pass_is_the_crates(&run);
            one_pass_is_the_crates(&vec![0; len]);
            let mut ends = run.clone();
            if let Some(b) = ends.first_mut() {
                *b = 0;
            }
            if let Some(b) = ends.last_mut() {
                *b = 0;
            }
            one_pass_is_the_crates(&ends);
        }
        let crc_with_zero = (0u32..)
            .map(u32::to_le_bytes)
            .find(|b| super::CRC.checksum(b).to_le_bytes().contains(&0))
            .expect("some body's CRC has a zero byte");
        one_pass_is_the_crates(&crc_with_zero);
    }

    proptest! {
        #[test]
        fn one_pass_is_the_crates_on_any_body(body in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>(), 1u8..], 0..=super::MAX_BODY)) {
            one_pass_is_the_crates(&body);
        }
    }
}
