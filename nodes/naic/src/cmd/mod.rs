//! One module per subcommand.

pub mod bag;
pub mod bench;
pub mod bench_chain;
pub mod friction;
pub mod launch;
pub mod plot;
pub mod record;
pub mod sim;

/// A command failure: a message for the user and whether it was their input.
#[derive(Debug)]
pub struct CliError {
    pub message: String,
    /// true: the user gave bad input (exit 2); false: the command failed (exit 1).
    pub usage: bool,
}

impl CliError {
    pub fn usage(msg: impl Into<String>) -> Self {
        Self { message: msg.into(), usage: true }
    }
    pub fn failure(msg: impl Into<String>) -> Self {
        Self { message: msg.into(), usage: false }
    }
    pub fn exit_code(&self) -> i32 {
        if self.usage { 2 } else { 1 }
    }
}

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub type CliResult = Result<(), CliError>;
