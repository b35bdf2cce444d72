//! Integration tests live in `tests/tests/`. This library holds what the
//! tests share with the fuzz targets of `fuzz/`: random guest code behind a
//! plugin's interface ([`smith`]).

pub mod smith;
