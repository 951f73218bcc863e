//! One module per subcommand.

pub mod bench;
pub mod demo;
pub mod extract;
pub mod generate;
pub mod info;
pub mod mc;
pub mod pack;
pub mod render;
pub mod serve;
pub mod view;
pub mod voxelize;
