//! The settings' flash: the last 8 KiB of the STM32G474's 512 KiB
//! (`memory.x` keeps them out of the image), as an `embedded-storage`
//! `NorFlash` for `instrument::store`.
//!
//! RM0440 3.3.6–3.3.8: unlock with the two keys, wait until not busy,
//! clear the error flags; a page erase sets PER with the page and bank,
//! then STRT; programming sets PG and writes a double word (two 32-bit
//! writes, the low address first), one at a time; every operation is
//! checked against the error flags, and the flash locked again after.
//! The data cache is reset after an erase (RM0440 3.3.3: it may hold the
//! erased words). On the G474RE in its default dual-bank mode (DBANK = 1)
//! pages are 2 KiB and the settings lie in bank 2, so the core keeps
//! fetching from bank 1 while they are written (read while write); in
//! single-bank mode pages are 4 KiB. The erase unit here is 4 KiB either
//! way.
//!
//! Every double word carries an ECC (RM0440 3.3.4). A double word whose
//! programming or erase the power cut can fail it: reading it sets
//! FLASH_ECCR.ECCD and raises an NMI. The NMI handler
//! (`board::runtime`) hands it to [`take_ecc_nmi`]: a failure within the
//! settings is cleared and counted, and the read that met it returns
//! [`FlashError::Ecc`], which the store takes as a slot that holds no set
//! (the other slot's set stays in force); anywhere else (the program)
//! the board resets.

use super::pac::flash;

/// Where the settings lie: the last 8 KiB of flash.
pub const SETTINGS_BASE: u32 = 0x0807_E000;
/// Their size, bytes: two slots of one erase unit.
pub const SETTINGS_BYTES: u32 = 8 * 1024;
/// The start of flash.
const FLASH_BASE: u32 = 0x0800_0000;
/// A bank in dual-bank mode, bytes.
const BANK_BYTES: u32 = 256 * 1024;

/// The erase unit, bytes: one 4 KiB page (single bank), or two 2 KiB
/// pages (dual bank).
pub const ERASE_UNIT: u32 = 4096;
/// The programming unit: a double word.
pub const WORD: u32 = 8;

/// FLASH_KEYR's two keys (RM0440 3.7.3).
pub const KEYS: [u32; 2] = [0x4567_0123, 0xCDEF_89AB];

/// A page: its bank (bank 2 in dual-bank mode) and number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Page {
    /// In bank 2 (BKER).
    pub bank2: bool,
    /// The page number (PNB, 0 … 127).
    pub number: u8,
}

/// The pages of the erase unit at `address`, which the caller aligns to
/// [`ERASE_UNIT`]: two 2 KiB pages in dual-bank mode, one 4 KiB page
/// otherwise.
pub fn pages(address: u32, dual_bank: bool) -> [Option<Page>; 2] {
    let offset = address - FLASH_BASE;
    match dual_bank {
        true => {
            let bank2 = offset >= BANK_BYTES;
            let number = ((offset % BANK_BYTES) / 2048) as u8;
            [
                Some(Page { bank2, number }),
                Some(Page {
                    bank2,
                    number: number + 1,
                }),
            ]
        }
        false => [
            Some(Page {
                bank2: false,
                number: (offset / 4096) as u8,
            }),
            None,
        ],
    }
}

/// Why a flash operation failed: FLASH_SR's error flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// OPERR: an operation failed.
    Operation,
    /// PROGERR: a double word programmed that was not erased.
    Programming,
    /// WRPERR: the address is write-protected.
    WriteProtected,
    /// PGAERR: not a double word's address.
    Alignment,
    /// SIZERR: not a 32-bit write.
    Size,
    /// PGSERR: the sequence was wrong (PG and PER, or flags left set).
    Sequence,
    /// MISERR: the double word's second half was not written in time.
    Miss,
    /// FASTERR: fast programming interrupted.
    Fast,
    /// An offset or length outside the settings' region, or not aligned.
    Bounds,
    /// A double word read whose ECC failed (two bits wrong): torn by a
    /// power cut; its bytes are not to be trusted.
    Ecc,
}

impl instrument::store::Corruption for FlashError {
    fn corrupt(&self) -> bool {
        *self == FlashError::Ecc
    }
}

/// FLASH_ECCR: ECCD, a double error detected (RM0440 3.7.8, bit 31).
pub const ECCR_ECCD: u32 = 1 << 31;
/// FLASH_ECCR: ECCD2, a double error in the second double word of a
/// 128-bit read (bit 29).
pub const ECCR_ECCD2: u32 = 1 << 29;
/// FLASH_ECCR: BK_ECC, the failure is in bank 2 (bit 21).
pub const ECCR_BK_ECC: u32 = 1 << 21;
/// FLASH_ECCR: ADDR_ECC, the failing address within its bank, bytes
/// (bits 18:0).
pub const ECCR_ADDR_ECC: u32 = 0x0007_FFFF;

/// The address of the double word whose double ECC error FLASH_ECCR
/// `eccr` reports (None: no double error): ADDR_ECC within the bank
/// BK_ECC names in dual-bank mode, within the whole flash otherwise.
pub fn ecc_failure(eccr: u32, dual_bank: bool) -> Option<u32> {
    if eccr & (ECCR_ECCD | ECCR_ECCD2) == 0 {
        return None;
    }
    let bank = match dual_bank && eccr & ECCR_BK_ECC != 0 {
        true => BANK_BYTES,
        false => 0,
    };
    Some(FLASH_BASE + bank + (eccr & ECCR_ADDR_ECC & !(WORD - 1)))
}

/// Whether `address` lies in the settings' region.
pub fn in_settings(address: u32) -> bool {
    (SETTINGS_BASE..SETTINGS_BASE + SETTINGS_BYTES).contains(&address)
}

/// The double ECC error FLASH_ECCR reports, if it lies in the settings:
/// its flags cleared (written back as 1; ECCIE kept), its address.
/// None, and nothing written, for none or one elsewhere.
pub fn take_settings_ecc(regs: &flash::RegisterBlock) -> Option<u32> {
    let eccr = regs.eccr().read().bits();
    let dual_bank = regs.optr().read().dbank().bit_is_set();
    let address = ecc_failure(eccr, dual_bank).filter(|&a| in_settings(a))?;
    regs.eccr().modify(|_, w| w.eccd().set_bit().eccd2().set_bit());
    Some(address)
}

/// The error flags of FLASH_SR, and their errors, first found first.
const ERRORS: [(u32, FlashError); 8] = [
    (1 << 1, FlashError::Operation),
    (1 << 3, FlashError::Programming),
    (1 << 4, FlashError::WriteProtected),
    (1 << 5, FlashError::Alignment),
    (1 << 6, FlashError::Size),
    (1 << 7, FlashError::Sequence),
    (1 << 8, FlashError::Miss),
    (1 << 9, FlashError::Fast),
];

/// The error flags (and EOP, bit 0) together.
pub const SR_CLEAR: u32 = 0x3FB;

/// FLASH_SR's busy flag.
pub fn busy(regs: &flash::RegisterBlock) -> bool {
    regs.sr().read().bsy().bit_is_set()
}

/// Read the error flags and clear them (and EOP): the first error set.
#[allow(unsafe_code)]
pub fn take_errors(regs: &flash::RegisterBlock) -> Result<(), FlashError> {
    let sr = regs.sr().read().bits();
    // SAFETY: SR's flags are cleared by writing 1; the other bits are
    // read-only or reserved and written as 0.
    regs.sr().write(|w| unsafe { w.bits(sr & SR_CLEAR) });
    match ERRORS.iter().find(|(bit, _)| sr & bit != 0) {
        Some(&(_, e)) => Err(e),
        None => Ok(()),
    }
}

/// Unlock FLASH_CR if it is locked: the two keys in order.
#[allow(unsafe_code)]
pub fn unlock(regs: &flash::RegisterBlock) {
    if regs.cr().read().lock().bit_is_set() {
        for key in KEYS {
            // SAFETY: the keys RM0440 gives; any value is accepted.
            regs.keyr().write(|w| unsafe { w.keyr().bits(key) });
        }
    }
}

/// Lock FLASH_CR again, as at reset (LOCK and OPTLOCK; PG and PER
/// cleared).
pub fn lock(regs: &flash::RegisterBlock) {
    regs.cr().write(|w| w.lock().set_bit());
}

/// Start erasing `page`: PER with its number and bank, then STRT. (CR
/// is written from 0, not from its reset value, which has LOCK set: a
/// write from the reset value would lock the flash again.)
#[allow(unsafe_code)]
pub fn start_erase(regs: &flash::RegisterBlock, page: Page) {
    // SAFETY: 0 is CR with nothing requested; PNB is 7 bits and page
    // numbers are 0 … 127.
    regs.cr().write(|w| unsafe {
        w.bits(0)
            .per()
            .set_bit()
            .pnb()
            .bits(page.number & 0x7F)
            .bker()
            .bit(page.bank2)
    });
    regs.cr().modify(|_, w| w.strt().set_bit());
}

/// Enter programming: PG and nothing else (written from 0, as for
/// [`start_erase`]).
#[allow(unsafe_code)]
pub fn start_program(regs: &flash::RegisterBlock) {
    // SAFETY: 0 is CR with nothing requested.
    regs.cr().write(|w| unsafe { w.bits(0).pg().set_bit() });
}

/// Leave programming or erasing: PG and PER cleared, still unlocked.
#[allow(unsafe_code)]
pub fn end_operation(regs: &flash::RegisterBlock) {
    // SAFETY: 0 clears PG, PER and STRT's request; LOCK is not cleared by
    // writing 0 (only the keys do that).
    regs.cr().write(|w| unsafe { w.bits(0) });
}

/// Reset the data cache (off, reset, on), so that reads after an erase
/// see the flash and not the cache.
pub fn reset_data_cache(regs: &flash::RegisterBlock) {
    regs.acr().modify(|_, w| w.dcen().clear_bit());
    regs.acr().modify(|_, w| w.dcrst().set_bit());
    regs.acr().modify(|_, w| w.dcrst().clear_bit());
    regs.acr().modify(|_, w| w.dcen().set_bit());
}

/// `offset .. offset + len` within the settings' region and aligned to
/// `align`.
pub fn in_region(offset: u32, len: usize, align: u32) -> Result<(), FlashError> {
    let end = u64::from(offset) + len as u64;
    match offset % align == 0 && len as u64 % u64::from(align) == 0 && end <= u64::from(SETTINGS_BYTES) {
        true => Ok(()),
        false => Err(FlashError::Bounds),
    }
}

#[cfg(target_os = "none")]
mod device {
    use super::*;
    use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

    use core::sync::atomic::{AtomicU32, Ordering};

    /// Double ECC errors met in the settings since start (the NMI
    /// handler counts them; a read compares the count before and after).
    static SETTINGS_ECC_ERRORS: AtomicU32 = AtomicU32::new(0);

    /// The NMI's cause, if it is a double ECC error within the settings:
    /// counted, FLASH_ECCR's flags cleared, true (the read that met it
    /// returns [`FlashError::Ecc`]). False for any other NMI.
    #[allow(unsafe_code)]
    pub fn take_ecc_nmi() -> bool {
        // SAFETY: the NMI preempts everything; ECCR and OPTR are read,
        // and ECCR's detection flags cleared by writing 1.
        let regs = unsafe { super::super::pac::FLASH::steal() };
        let ours = take_settings_ecc(&regs).is_some();
        if ours {
            SETTINGS_ECC_ERRORS.fetch_add(1, Ordering::Relaxed);
        }
        ours
    }

    impl NorFlashError for FlashError {
        fn kind(&self) -> NorFlashErrorKind {
            match self {
                FlashError::Bounds => NorFlashErrorKind::OutOfBounds,
                FlashError::Alignment => NorFlashErrorKind::NotAligned,
                _ => NorFlashErrorKind::Other,
            }
        }
    }

    /// The settings' region of the board's flash.
    pub struct SettingsFlash {
        regs: super::super::pac::FLASH,
        dual_bank: bool,
    }

    impl SettingsFlash {
        /// Over the flash controller; the bank mode read from FLASH_OPTR.
        pub fn new(regs: super::super::pac::FLASH) -> Self {
            let dual_bank = regs.optr().read().dbank().bit_is_set();
            Self { regs, dual_bank }
        }

        fn wait(&self) -> Result<(), FlashError> {
            while busy(&self.regs) {}
            take_errors(&self.regs)
        }
    }

    impl ErrorType for SettingsFlash {
        type Error = FlashError;
    }

    impl ReadNorFlash for SettingsFlash {
        const READ_SIZE: usize = 1;

        #[allow(unsafe_code)]
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            in_region(offset, bytes.len(), 1)?;
            let before = SETTINGS_ECC_ERRORS.load(Ordering::Relaxed);
            let at = (SETTINGS_BASE + offset) as *const u8;
            for (k, b) in bytes.iter_mut().enumerate() {
                // SAFETY: within the settings' region of flash (checked).
                *b = unsafe { core::ptr::read_volatile(at.add(k)) };
            }
            // A torn double word raised its NMI during the loop.
            match SETTINGS_ECC_ERRORS.load(Ordering::Relaxed) == before {
                true => Ok(()),
                false => Err(FlashError::Ecc),
            }
        }

        fn capacity(&self) -> usize {
            SETTINGS_BYTES as usize
        }
    }

    impl NorFlash for SettingsFlash {
        const WRITE_SIZE: usize = WORD as usize;
        const ERASE_SIZE: usize = ERASE_UNIT as usize;

        fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            if to < from {
                return Err(FlashError::Bounds);
            }
            in_region(from, (to - from) as usize, ERASE_UNIT)?;
            unlock(&self.regs);
            let mut result = self.wait();
            for unit in (from..to).step_by(ERASE_UNIT as usize) {
                for page in pages(SETTINGS_BASE + unit, self.dual_bank).into_iter().flatten() {
                    if result.is_ok() {
                        start_erase(&self.regs, page);
                        result = self.wait();
                        end_operation(&self.regs);
                    }
                }
            }
            reset_data_cache(&self.regs);
            lock(&self.regs);
            result
        }

        #[allow(unsafe_code)]
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            in_region(offset, bytes.len(), WORD)?;
            unlock(&self.regs);
            let mut result = self.wait();
            if result.is_ok() {
                start_program(&self.regs);
                for (k, word) in bytes.chunks_exact(WORD as usize).enumerate() {
                    let at = (SETTINGS_BASE + offset) as usize + k * WORD as usize;
                    let lo = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
                    let hi = u32::from_le_bytes([word[4], word[5], word[6], word[7]]);
                    // SAFETY: a double word of the settings' region
                    // (checked), written as two 32-bit writes, low first,
                    // with PG set (RM0440 3.3.7).
                    unsafe {
                        core::ptr::write_volatile(at as *mut u32, lo);
                        core::ptr::write_volatile((at + 4) as *mut u32, hi);
                    }
                    result = self.wait();
                    if result.is_err() {
                        break;
                    }
                }
                end_operation(&self.regs);
            }
            lock(&self.regs);
            result
        }
    }
}

#[cfg(target_os = "none")]
pub use device::{take_ecc_nmi, SettingsFlash};
