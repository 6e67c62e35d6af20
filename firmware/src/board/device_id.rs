//! The board's device id, which its start frame reports: the CRC-32 of the
//! STM32G474's 96-bit unique device ID (RM0440 §48.1: three words at
//! 0x1FFF_7590, the die's wafer coordinates, wafer and lot number, written
//! at the factory), so that a host reading several boards tells them apart
//! and a skin description names each by it.

/// Where the unique device ID is (RM0440 §48.1, `UID_BASE`).
#[cfg(target_os = "none")]
const UID_BASE: usize = 0x1FFF_7590;

/// The id of the 96-bit unique device ID `uid` (its words little-endian).
pub fn of(uid: [u32; 3]) -> u32 {
    let mut bytes = [0u8; 12];
    for (b, w) in bytes.chunks_exact_mut(4).zip(uid) {
        b.copy_from_slice(&w.to_le_bytes());
    }
    ::link::CRC.checksum(&bytes)
}

/// This board's id ([`of`] its unique device ID).
#[cfg(target_os = "none")]
pub fn read() -> u32 {
    // SAFETY: the unique device ID is three read-only words of system
    // memory, always readable (RM0440 §48.1).
    #[allow(unsafe_code)]
    let uid = core::array::from_fn(|k| unsafe { core::ptr::read_volatile((UID_BASE as *const u32).add(k)) });
    of(uid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_id_is_the_crc_of_the_uid_bytes() {
        // CRC-32/ISO-HDLC of the twelve bytes, as Python's zlib.crc32
        // gives it.
        assert_eq!(of([0x0030_0021, 0x5734_5009, 0x2037_3835]), 0xFF14_4B7B);
        assert_ne!(of([1, 2, 3]), of([1, 2, 4]));
    }
}
