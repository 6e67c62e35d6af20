//! What a device says of its stored settings at start: `settings: none
//! stored`, or the generation and digest of the set in force (the digest
//! a host computes of the same set with `instrument::digest`).

use instrument::digest::Digest;
use instrument::store::{Loaded, StoreError};

/// Log the set in force, as [`instrument::store::Store::load`] found it.
pub fn announce<E>(loaded: &Result<Option<Loaded>, StoreError<E>>) {
    match loaded {
        Ok(Some(l)) => defmt::println!(
            "settings: generation {=u32} digest {=u32:#010x}",
            l.generation,
            Digest::of(&l.set)
        ),
        Ok(None) => defmt::println!("settings: none stored"),
        Err(_) => defmt::println!("settings: the flash cannot be read"),
    }
}
