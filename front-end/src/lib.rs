//! The reference analog front end of the boards, written once: each
//! board is a [`circuit::Circuit`] of orderable [`parts`], from which
//! the SPICE netlist ([`circuit::Circuit::netlist`]), the bill of
//! materials ([`bom`]) and the schematic ([`schematic`]) are generated,
//! so that they cannot disagree. ngspice ([`spice`]) runs the netlist
//! against the constants the firmware assumes (`tests/`).

pub mod array;
pub mod blocks;
pub mod bom;
pub mod circuit;
pub mod files;
pub mod models;
pub mod mux;
pub mod parts;
pub mod schematic;
pub mod spice;
