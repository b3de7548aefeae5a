//! One module per subcommand: flag definitions and printing only.

pub mod synth;
