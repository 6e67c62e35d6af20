//! The README's table of headline figures is the rows of the tables in
//! `docs/figures.md`, each of which the test that measures it checks.

/// The headline tables, in the README's order: (file, block).
const SOURCES: [(&str, &str); 5] = [
    ("docs/figures.md", "headline-multiplexed"),
    ("docs/figures.md", "headline-array"),
    ("docs/figures.md", "headline-array-1ms"),
    ("docs/figures.md", "headline-paper"),
    ("docs/figures.md", "headline-speed"),
];

#[test]
fn the_readme_headline_table_is_the_measured_rows() {
    figures::assemble("README.md", "headline", &SOURCES).unwrap();
}
