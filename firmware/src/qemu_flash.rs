//! The settings' flash in QEMU: 8 KiB of NOR flash kept in a host file
//! through semihosting, so that stored settings survive a restart of
//! QEMU. The same units and rule as the board's (`board::flash`: 8-byte
//! words, 4 KiB erase units, a word programmed only where erased), so
//! `instrument::store` runs unchanged; a missing file is a new device
//! (erased), a file of another length is refused.

use core::ffi::CStr;
use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};
use instrument::digest::Digest;
use instrument::store::{Store, StoreError, REGION_BYTES, SLOT_BYTES};
use instrument::stored::Stored;
use semihosting::fs::{File, OpenOptions};
use semihosting::io::{Read, Seek, SeekFrom, Write};

/// Why an operation on the file failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFlashError {
    /// The host refused a file operation.
    Host,
    /// Outside the region, or not aligned.
    Bounds,
    /// A word programmed that was not erased.
    NotErased,
    /// The file is not 8 KiB.
    Length,
}

/// A host file has no ECC: an error is the host's, never torn bytes.
impl instrument::store::Corruption for FileFlashError {
    fn corrupt(&self) -> bool {
        false
    }
}

impl NorFlashError for FileFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FileFlashError::Bounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// The settings' flash in a host file.
pub struct FileFlash {
    file: File,
}

/// Erased bytes, a unit's worth at a time.
const ERASED: [u8; 256] = [0xFF; 256];

impl FileFlash {
    /// The flash in the file at `path` (relative to QEMU's folder):
    /// opened if it is there, created erased if not.
    pub fn open(path: &CStr) -> Result<Self, FileFlashError> {
        if let Ok(file) = OpenOptions::new().read(true).write(true).open(path) {
            let len = file.metadata().map_err(|_| FileFlashError::Host)?.len();
            return match len == REGION_BYTES as u64 {
                true => Ok(Self { file }),
                false => Err(FileFlashError::Length),
            };
        }
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(|_| FileFlashError::Host)?;
        let mut flash = Self { file };
        flash.fill(0, REGION_BYTES)?;
        Ok(flash)
    }

    fn seek(&mut self, at: usize) -> Result<(), FileFlashError> {
        self.file
            .seek(SeekFrom::Start(at as u64))
            .map(|_| ())
            .map_err(|_| FileFlashError::Host)
    }

    /// `len` erased bytes from `at`.
    fn fill(&mut self, at: usize, len: usize) -> Result<(), FileFlashError> {
        self.seek(at)?;
        let mut left = len;
        while left > 0 {
            let n = left.min(ERASED.len());
            self.file
                .write_all(&ERASED[..n])
                .map_err(|_| FileFlashError::Host)?;
            left -= n;
        }
        Ok(())
    }
}

/// `offset .. offset + len` within the region and aligned to `align`.
fn in_region(offset: u32, len: usize, align: usize) -> Result<usize, FileFlashError> {
    let at = offset as usize;
    match at % align == 0 && len % align == 0 && at.checked_add(len).is_some_and(|e| e <= REGION_BYTES) {
        true => Ok(at),
        false => Err(FileFlashError::Bounds),
    }
}

impl ErrorType for FileFlash {
    type Error = FileFlashError;
}

impl ReadNorFlash for FileFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FileFlashError> {
        let at = in_region(offset, bytes.len(), 1)?;
        self.seek(at)?;
        self.file.read_exact(bytes).map_err(|_| FileFlashError::Host)
    }

    fn capacity(&self) -> usize {
        REGION_BYTES
    }
}

impl NorFlash for FileFlash {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = 4096;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FileFlashError> {
        if to < from {
            return Err(FileFlashError::Bounds);
        }
        let at = in_region(from, (to - from) as usize, Self::ERASE_SIZE)?;
        self.fill(at, (to - from) as usize)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FileFlashError> {
        let at = in_region(offset, bytes.len(), Self::WRITE_SIZE)?;
        // NOR: only erased words take a program.
        let mut word = [0u8; 8];
        for k in (0..bytes.len()).step_by(8) {
            self.read(offset + k as u32, &mut word)?;
            if word.iter().any(|&b| b != 0xFF) {
                return Err(FileFlashError::NotErased);
            }
        }
        self.seek(at)?;
        self.file.write_all(bytes).map_err(|_| FileFlashError::Host)
    }
}

/// The stored settings at start, in the flash file at `path`: say what is
/// stored (`settings: none stored`, or its generation and digest); with
/// `save`, store `save` as the new set and say so. Returns the store, for
/// the requests that come down the link, and the set it now holds with
/// its generation (None: nothing stored, or the flash unreadable). A file that cannot be opened
/// or a set refused ends the run with exit code 2, as a bad command line
/// does.
fn keep(path: &CStr, save: Option<&Stored>) -> (Store<FileFlash>, Option<(u32, Stored)>) {
    let flash = FileFlash::open(path).unwrap_or_else(|e| {
        defmt::println!(
            "settings: the flash file cannot be used ({})",
            defmt::Debug2Format(&e)
        );
        crate::qemu::exit(2)
    });
    let Ok(mut store) = Store::new(flash, 0, SLOT_BYTES) else {
        defmt::println!("settings: the slots do not fit the flash");
        crate::qemu::exit(2)
    };
    let loaded = store.load();
    crate::settings_log::announce(&loaded);
    let mut set = loaded.ok().flatten().map(|l| (l.generation, l.set));
    if let Some(new) = save {
        match store.save(new) {
            Ok(g) => {
                defmt::println!(
                    "settings saved: generation {=u32} digest {=u32:#010x}",
                    g,
                    Digest::of(new)
                );
                set = Some((g, *new));
            }
            Err(StoreError::Refused(r)) => {
                defmt::println!("settings refused: {}", defmt::Display2Format(&r));
                crate::qemu::exit(2)
            }
            Err(e) => defmt::println!("settings not saved ({})", defmt::Debug2Format(&e)),
        }
    }
    (store, set)
}

/// The command line's settings options: `flash=PATH` (the settings'
/// flash in a host file), `save` (store the run's own set there),
/// `until-stop` (measure past the scenario's end, until the host's stop
/// request: a host that talks to the device is never raced by the
/// scenario's clock) and `device=N` (the id its start frame reports).
#[derive(Default)]
pub struct FlashArgs {
    /// `flash=PATH`, NUL-terminated for the host's open.
    path: Option<heapless::Vec<u8, 128>>,
    /// `save`.
    save: bool,
    /// `until-stop`.
    until_stop: bool,
    /// `device=N`: the device id the start frame reports (0 without),
    /// as a board reports its chip's (`board::device_id`).
    pub device: u32,
}

impl FlashArgs {
    /// Take `arg` if it is one of these options (true); a path longer
    /// than 127 bytes ends the run with exit code 2.
    pub fn take(&mut self, arg: &str) -> bool {
        if let Some(path) = arg.strip_prefix("flash=") {
            let mut p = heapless::Vec::new();
            if p.extend_from_slice(path.as_bytes()).is_err() || p.push(0).is_err() {
                defmt::println!("flash=: the path is longer than 127 bytes");
                crate::qemu::exit(2)
            }
            self.path = Some(p);
            return true;
        }
        if arg == "save" {
            self.save = true;
            return true;
        }
        if arg == "until-stop" {
            self.until_stop = true;
            return true;
        }
        if let Some(id) = arg.strip_prefix("device=") {
            let parsed = match id.strip_prefix("0x") {
                Some(hex) => u32::from_str_radix(hex, 16),
                None => id.parse(),
            };
            let Ok(id) = parsed else {
                defmt::println!("device=: not a 32-bit number (decimal, or hex after 0x)");
                crate::qemu::exit(2)
            };
            self.device = id;
            return true;
        }
        false
    }

    /// The step (block or slot) at which a run of `steps` steps ends:
    /// `steps`, or never with `until-stop` (the host's stop ends it).
    pub fn end_step(&self, steps: u64) -> u64 {
        if self.until_stop {
            u64::MAX
        } else {
            steps
        }
    }

    /// The set a run measures with: with `flash=`, the set the file holds
    /// (after `save`, `rig`, the test rig's description of its simulated
    /// skin), or with nothing stored, sensors nothing was measured on
    /// ([`Stored::uncalibrated`], and the log says so); without it,
    /// `rig`; with its generation (0: none stored). And the store, for the
    /// requests down the link.
    #[inline(never)]
    pub fn set_in_force(&self, rig: &Stored) -> (Option<Store<FileFlash>>, (u32, Stored)) {
        let Some(path) = &self.path else {
            return (None, (0, *rig));
        };
        let Ok(path) = CStr::from_bytes_with_nul(path) else {
            defmt::println!("flash=: the path holds a NUL");
            crate::qemu::exit(2)
        };
        let (store, set) = keep(path, self.save.then_some(rig));
        let set = set.unwrap_or_else(|| {
            defmt::println!("settings: measuring uncalibrated (no leads, no wiring, stretch not calibrated)");
            (0, Stored::uncalibrated())
        });
        (Some(store), set)
    }
}

/// The set `store` holds taken into `in_force` after the host stored
/// it, at device time `t_us` ([`crate::in_force::InForce::apply_stored`]),
/// logged, and its frame sent on `link`.
pub fn apply<C: crate::in_force::Shared<S>, const S: usize>(
    in_force: &mut crate::in_force::InForce<C, S>,
    store: &mut Store<FileFlash>,
    link: &mut crate::qemu::LinkSender,
    t_us: u64,
) {
    let applied = in_force.apply_stored(store, t_us);
    crate::settings_log::applied(&applied);
    if let Ok(a) = applied {
        link.applied(&a);
    }
}

/// What the host's requests asked of the application.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Asked {
    /// Stop measuring.
    pub stop: bool,
    /// Sweep every tone pair, this many blocks each (a calibration step).
    pub sweep: Option<u16>,
    /// A new set is stored: apply it.
    pub apply: bool,
}

/// Answer the requests the host sent down the link: with the store,
/// [`instrument::commands`]; without one, every request refused (the
/// settings cannot be kept). What the host asked for.
pub fn answer(
    link: &mut crate::qemu::LinkSender,
    commands: &mut instrument::commands::Commands,
    store: Option<&mut Store<FileFlash>>,
) -> Asked {
    use instrument::commands::Action;
    let mut asked = Asked::default();
    let mut store = store;
    while let Some((seq, req)) = link.request() {
        let action = match store.as_deref_mut() {
            Some(store) => commands.handle(seq, &req, store, |r| link.reply(r)),
            None => {
                link.reply(link::Reply::Refused {
                    to: seq,
                    reason: link::Reason::Flash,
                });
                Action::None
            }
        };
        match action {
            Action::Stop => asked.stop = true,
            Action::Sweep(n) => asked.sweep = Some(n),
            Action::Apply => asked.apply = true,
            Action::Start | Action::None => {}
        }
    }
    asked
}
