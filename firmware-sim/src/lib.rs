//! fringe3d scan-head firmware logic (placeholder: the head arrives with the device issue).
#![no_std]
#![deny(unsafe_code, missing_docs)]
