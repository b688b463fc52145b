//! The sweep service: stores for sweeps and their variants, and the PostgreSQL work
//! queue that worker processes on other machines pull from.

pub mod pg;
