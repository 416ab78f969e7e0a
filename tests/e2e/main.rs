//! End-to-end tests: run the `citylod` binary on real data and hand its output to the external checkers
//! (Khronos glTF-Validator through node, the JSON Schemas in `schemas/`) and to citylod's own tileset reader.
//! The tilesets are kept under `target/e2e/<name>` for the browser tests (`tests/browser/`) and for people.

mod bad_input;
mod check;
mod common;
mod models;
mod real_data;
