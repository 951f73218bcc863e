//! The `isogrid` binary end to end, one test binary: `cli` (JSON names, files it writes, how it
//! fails on bad input; colour, labels and hostile inputs), `render` (PNG, AOVs and `bench rays`),
//! `serve` (HTTP with ranges) and `view` (the window under Xvfb).

mod cli;
mod common;
mod render;
mod serve;
mod view;
