//! Test-only crate: see `tests/parsers.rs`. The budget per property is set with
//! `PROPTEST_CASES` (default here: a few hundred cases, seconds in release mode).
