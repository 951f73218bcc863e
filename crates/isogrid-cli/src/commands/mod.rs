//! One module per subcommand.

pub mod demo;
pub mod extract;
pub mod generate;
pub mod info;
pub mod mc;
pub mod view;
pub mod voxelize;
