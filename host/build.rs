// The compiler probe shared with the core crate: see its documentation there.
include!("../core/build.rs");
