//! The netlist, the bill of materials and the schematic in the
//! repository are what each board's circuit gives.

use front_end::{array, files, mux};

#[test]
fn the_array_boards_files_are_its_circuits() {
    let update = std::env::var_os(figures::UPDATE_VAR).is_some();
    files::check("array", &array::board(), update).unwrap();
}

#[test]
fn the_multiplexed_boards_files_are_its_circuits() {
    let update = std::env::var_os(figures::UPDATE_VAR).is_some();
    files::check("mux", &mux::board(), update).unwrap();
}

/// Every ordered part has a manufacturer's number, and every element of
/// the netlist but the Nucleo's pins is ordered.
#[test]
fn every_part_is_orderable() {
    for board in [array::board(), mux::board()] {
        orderable(&board);
    }
}

fn orderable(board: &front_end::circuit::Circuit) {
    let bom = front_end::bom::csv(board).unwrap();
    let mut rows = csv::Reader::from_reader(bom.as_bytes());
    let mut count = 0;
    for row in rows.records() {
        let row = row.unwrap();
        assert!(!row[5].is_empty() && !row[6].is_empty(), "{row:?}");
        count += row[1].parse::<usize>().unwrap();
    }
    let ordered = board.elements.iter().filter(|e| e.part.is_some()).count();
    assert_eq!(count, ordered);
    let pins = board.elements.iter().filter(|e| e.part.is_none()).count();
    assert_eq!(pins + ordered, board.elements.len());
}
