//! The store against a model of NOR flash that loses power: at any
//! operation of an update, the operation under way is left half done (a
//! page partly erased, a word partly programmed: random bits), and every
//! later one fails. Then the device restarts and loads. As on the G474,
//! each double word carries an ECC: a torn word may read back as an ECC
//! error instead of bytes (RM0440 3.3.4: a double error, an NMI the board
//! turns into a read error).

use super::*;
use crate::stored::SENSORS_MAX;
use embedded_storage::nor_flash::{ErrorType, NorFlashError, NorFlashErrorKind, ReadNorFlash};
use std::println;
use std::string::ToString;
use std::vec;
use std::vec::Vec;

/// The G474's flash as the store sees it: 2 KiB pages, double words.
const PAGE: usize = 2048;
const WORD: usize = 8;

/// Two slots of two pages.
const SLOT: u32 = 2 * PAGE as u32;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ModelError {
    /// The power went.
    PowerLost,
    /// A word programmed that was not erased (the G474's PROGERR).
    NotErased,
    /// A word whose ECC does not check (double error detected).
    Ecc,
    /// Outside the flash, or not aligned.
    Bounds,
}

impl Corruption for ModelError {
    fn corrupt(&self) -> bool {
        *self == ModelError::Ecc
    }
}

impl NorFlashError for ModelError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            ModelError::Bounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// NOR flash in RAM that loses power after `ops_left` page erases and
/// word programs.
#[derive(Clone)]
struct Model {
    mem: Vec<u8>,
    /// Words whose ECC does not check (torn by a cut).
    torn: Vec<bool>,
    ops_left: Option<usize>,
    ops: usize,
    dead: bool,
    rng: u64,
}

impl Model {
    fn new(pages: usize) -> Self {
        Self {
            mem: vec![0xFF; pages * PAGE],
            torn: vec![false; pages * PAGE / WORD],
            ops_left: None,
            ops: 0,
            dead: false,
            rng: 0x9E37_79B9_7F4A_7C15,
        }
    }

    fn random(&mut self) -> u8 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        self.rng as u8
    }

    /// One more operation; false (and the power gone) if it is the one
    /// the power fails in.
    fn step(&mut self) -> Result<bool, ModelError> {
        if self.dead {
            return Err(ModelError::PowerLost);
        }
        self.ops += 1;
        match &mut self.ops_left {
            Some(0) => {
                self.dead = true;
                Ok(false)
            }
            Some(n) => {
                *n -= 1;
                Ok(true)
            }
            None => Ok(true),
        }
    }
}

impl ErrorType for Model {
    type Error = ModelError;
}

impl ReadNorFlash for Model {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), ModelError> {
        let at = offset as usize;
        let src = self.mem.get(at..at + bytes.len()).ok_or(ModelError::Bounds)?;
        if (at / WORD..(at + bytes.len()).div_ceil(WORD)).any(|w| self.torn[w]) {
            return Err(ModelError::Ecc);
        }
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for Model {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), ModelError> {
        let (from, to) = (from as usize, to as usize);
        if from % PAGE != 0 || to % PAGE != 0 || to > self.mem.len() {
            return Err(ModelError::Bounds);
        }
        for page in (from..to).step_by(PAGE) {
            if !self.step()? {
                // Half erased: some bytes back to 0xFF, the rest as they were
                // or garbled.
                for k in page..page + PAGE {
                    let r = self.random();
                    self.mem[k] = match r % 3 {
                        0 => 0xFF,
                        1 => self.mem[k],
                        _ => r,
                    };
                }
                // Some words' ECC no longer checks.
                for w in page / WORD..(page + PAGE) / WORD {
                    if self.random() % 4 == 0 {
                        self.torn[w] = true;
                    }
                }
                return Err(ModelError::PowerLost);
            }
            self.mem[page..page + PAGE].fill(0xFF);
            self.torn[page / WORD..(page + PAGE) / WORD].fill(false);
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), ModelError> {
        let at = offset as usize;
        if at % WORD != 0 || bytes.len() % WORD != 0 || at + bytes.len() > self.mem.len() {
            return Err(ModelError::Bounds);
        }
        for (w, word) in bytes.chunks(WORD).enumerate() {
            let dst = at + w * WORD;
            if self.mem[dst..dst + WORD].iter().any(|&b| b != 0xFF) {
                return Err(ModelError::NotErased);
            }
            if !self.step()? {
                // Half programmed: programming only clears bits.
                for (k, &b) in word.iter().enumerate() {
                    let r = self.random();
                    self.mem[dst + k] = b | r;
                }
                // Half the time its ECC is torn too.
                self.torn[dst / WORD] = self.random() % 2 == 0;
                return Err(ModelError::PowerLost);
            }
            self.mem[dst..dst + WORD].copy_from_slice(word);
        }
        Ok(())
    }
}

/// Set `k` of a sequence: every sensor's values moved a little.
fn set(k: u32) -> Stored {
    let mut s = Stored::uncalibrated();
    for (i, sensor) in s.sensors.iter_mut().enumerate() {
        sensor.nominal_c_farad *= 1.0 + 0.01 * k as f32 + 0.001 * i as f32;
        sensor.parasitic_farad = k as f32 * 1e-12;
        sensor.calibrated = k % 2 == 1;
    }
    s.record_every = 1 + k as u8;
    s
}

fn store(model: Model) -> Store<Model> {
    Store::new(model, 4 * PAGE as u32, SLOT).unwrap()
}

/// A restart: the store over what the flash holds, power back.
fn restart(model: &Model) -> Store<Model> {
    let mut m = model.clone();
    m.ops_left = None;
    m.dead = false;
    store(m)
}

#[test]
fn a_power_cut_at_every_step_of_an_update_leaves_the_old_set_or_the_new() {
    let mut flash = store(Model::new(8));
    assert_eq!(flash.load(), Ok(None), "a new device holds nothing");
    assert_eq!(flash.save(&set(0)), Ok(1));
    let mut cut_points = 0;
    let (mut old_seen, mut new_seen) = (0, 0);
    for k in 1..=6u32 {
        let before = flash.release();
        // How many operations a whole update takes.
        let mut probe = store(before.clone());
        assert_eq!(probe.save(&set(k)), Ok(k + 1));
        let ops = probe.release().ops - before.ops;
        assert!(ops > (crate::stored::MAX_BYTES / 2) / WORD, "{ops} operations");
        for cut in 0..ops {
            cut_points += 1;
            let mut m = before.clone();
            m.ops_left = Some(cut);
            let mut s = store(m);
            assert!(s.save(&set(k)).is_err(), "cut {cut} of {ops}");
            let cut_flash = s.release();
            let loaded = restart(&cut_flash).load().unwrap().expect("never none");
            if loaded.set == set(k - 1) {
                assert_eq!(loaded.generation, k);
                old_seen += 1;
            } else {
                assert_eq!(loaded.set, set(k), "cut {cut} of {ops}: neither set");
                assert_eq!(loaded.generation, k + 1);
                new_seen += 1;
            }
            // And the device goes on: the next update after the restart
            // lands.
            if cut % 97 == 0 {
                let mut again = restart(&cut_flash);
                let g = again.save(&set(k)).unwrap();
                assert_eq!(
                    again.load().unwrap().map(|l| (l.set, l.generation)),
                    Some((set(k), g))
                );
            }
        }
        flash = store(before);
        assert_eq!(flash.save(&set(k)), Ok(k + 1));
        assert_eq!(
            restart(flash.release_ref()).load().unwrap().map(|l| l.set),
            Some(set(k))
        );
    }
    println!("{cut_points} cut points: {old_seen} old, {new_seen} new");
    assert!(cut_points >= 1000, "{cut_points}");
    // A cut leaves the new set only where the update was in fact done: in
    // the header's last word, which is padding (all ones, so a half
    // program of it is a whole one); one per update.
    assert_eq!(new_seen, 6, "{new_seen}");
}

#[test]
fn a_refused_set_touches_nothing_and_says_why() {
    let mut flash = store(Model::new(8));
    assert_eq!(flash.save(&set(0)), Ok(1));
    let before = flash.release_ref().mem.clone();
    let mut bad = set(1);
    bad.sensors[SENSORS_MAX - 1].table.swap(0, 1);
    match flash.save(&bad) {
        Err(StoreError::Refused(r)) => {
            assert_eq!(r.to_string(), "sensor 15 table: must ascend in C and in stretch")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(flash.release_ref().mem, before);
    assert_eq!(flash.load().unwrap().map(|l| l.set), Some(set(0)));
}

#[test]
fn garbage_in_both_slots_loads_as_nothing_and_a_save_recovers() {
    let mut m = Model::new(8);
    for k in 0..m.mem.len() {
        m.mem[k] = m.random();
    }
    // Programming over garbage fails (not erased) until a slot is erased,
    // which `save` does first.
    let mut flash = store(m);
    assert_eq!(flash.load(), Ok(None));
    assert_eq!(flash.save(&set(3)), Ok(1));
    assert_eq!(flash.load().unwrap().map(|l| l.set), Some(set(3)));
}

#[test]
fn generations_alternate_slots_and_wrap() {
    let mut flash = store(Model::new(8));
    for k in 0..5 {
        let g = flash.save(&set(k)).unwrap();
        let l = flash.load().unwrap().unwrap();
        assert_eq!((l.generation, l.slot, l.set), (g, (k as usize) % 2, set(k)));
    }
    assert!(newer(0, u32::MAX) && !newer(u32::MAX, 0) && !newer(5, 5));
}

#[test]
fn a_layout_that_does_not_fit_is_refused() {
    assert!(matches!(
        Store::new(Model::new(8), 100, SLOT),
        Err(StoreError::Layout(_))
    ));
    assert!(matches!(
        Store::new(Model::new(8), 0, PAGE as u32),
        Err(StoreError::Layout(_))
    ));
    assert!(matches!(
        Store::new(Model::new(8), 6 * PAGE as u32, SLOT),
        Err(StoreError::Layout(_))
    ));
}

impl Store<Model> {
    /// The model, borrowed.
    fn release_ref(&self) -> &Model {
        &self.flash
    }
}

#[test]
fn a_ram_flash_image_holds_a_set_as_the_board_would() {
    let mut mem = vec![0xFFu8; REGION_BYTES];
    {
        let mut s = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
        assert_eq!(s.save(&set(2)), Ok(1));
    }
    // The image again, as a restart would find it.
    let mut again = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
    assert_eq!(again.load().unwrap().map(|l| l.set), Some(set(2)));
    // NOR's rule holds: no programming over programmed words.
    let mut f = RamFlash::new(&mut mem);
    assert_eq!(f.write(0, &[0u8; 8]), Err(RamFlashError::NotErased));
    assert_eq!(f.write(4, &[0u8; 8]), Err(RamFlashError::Bounds));
    assert_eq!(f.erase(0, 100), Err(RamFlashError::Bounds));
}

/// A set staged in pieces of any length (not whole flash words, as the
/// link's last piece is not) commits to the set itself; a commit whose
/// CRC or bytes do not hold leaves the set in force, and the slot in
/// force is never written while a set is staged.
#[test]
fn a_set_staged_in_pieces_of_any_length_is_the_set() {
    let mut flash = store(Model::new(8));
    assert_eq!(flash.save(&set(0)), Ok(1));
    let mut buf = [0u8; MAX_BYTES];
    let bytes = set(1).to_bytes(&mut buf).unwrap().to_vec();
    let crc = link::CRC.checksum(&bytes);
    for sizes in [&[1usize, 3, 8, 13, 32, 5][..], &[7], &[32], &[bytes.len()]] {
        let before = flash.load().unwrap().unwrap();
        let mut staged = flash.begin().unwrap();
        assert_ne!(staged.slot, before.slot, "staged beside the set in force");
        let mut rest = &bytes[..];
        for &n in sizes.iter().cycle() {
            if rest.is_empty() {
                break;
            }
            let n = n.min(rest.len());
            flash.append(&mut staged, &rest[..n]).unwrap();
            rest = &rest[n..];
            assert_eq!(flash.load().unwrap(), Some(before), "in force while staged");
        }
        assert_eq!(staged.len(), bytes.len());
        // A wrong CRC: refused, nothing in force changes.
        assert_eq!(flash.commit(staged, crc ^ 1), Err(StoreError::Mismatch));
        assert_eq!(flash.load().unwrap(), Some(before));
        // Staged again, with the right one: in force, a generation on.
        let mut staged = flash.begin().unwrap();
        for piece in bytes.chunks(sizes[0]) {
            flash.append(&mut staged, piece).unwrap();
        }
        let g = flash.commit(staged, crc).unwrap();
        assert_eq!(g, before.generation + 1);
        let loaded = restart(flash.release_ref()).load().unwrap().unwrap();
        assert_eq!((loaded.set, loaded.generation), (set(1), g));
    }
    // Bytes with a matching CRC that are not a set.
    let junk = [0x55u8; 40];
    let mut staged = flash.begin().unwrap();
    flash.append(&mut staged, &junk).unwrap();
    assert_eq!(
        flash.commit(staged, link::CRC.checksum(&junk)),
        Err(StoreError::Malformed)
    );
    assert_eq!(flash.load().unwrap().map(|l| l.set), Some(set(1)));
}

/// A flash whose header writes come back with a bit flipped: the
/// commit's read-back of its header catches it, the slot is taken out of
/// the running, and the set in force stays.
#[test]
fn a_header_that_does_not_read_back_is_not_put_in_force() {
    struct FlipHeaders<'a>(RamFlash<'a>);
    impl ErrorType for FlipHeaders<'_> {
        type Error = RamFlashError;
    }
    impl ReadNorFlash for FlipHeaders<'_> {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
            self.0.read(offset, bytes)
        }
        fn capacity(&self) -> usize {
            self.0.capacity()
        }
    }
    impl NorFlash for FlipHeaders<'_> {
        const WRITE_SIZE: usize = RamFlash::WRITE_SIZE;
        const ERASE_SIZE: usize = RamFlash::ERASE_SIZE;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
            self.0.erase(from, to)
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
            let mut b = bytes.to_vec();
            if offset % SLOT_BYTES == 0 && bytes.len() == HEADER {
                b[4] ^= 0x01;
            }
            self.0.write(offset, &b)
        }
    }
    let mut mem = vec![0xFFu8; REGION_BYTES];
    {
        let mut good = Store::new(RamFlash::new(&mut mem), 0, SLOT_BYTES).unwrap();
        assert_eq!(good.save(&set(0)), Ok(1));
    }
    let mut bad = Store::new(FlipHeaders(RamFlash::new(&mut mem)), 0, SLOT_BYTES).unwrap();
    assert_eq!(bad.save(&set(1)), Err(StoreError::Verify));
    let loaded = bad.load().unwrap().unwrap();
    assert_eq!((loaded.set, loaded.generation), (set(0), 1));
    // Its slot was erased: nothing of the failed set is left.
    let other = 1 - loaded.slot;
    assert!(mem[other * SLOT_BYTES as usize..][..HEADER]
        .iter()
        .all(|&b| b == 0xFF));
}
