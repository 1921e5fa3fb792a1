//! `waggle payload`: a six-bit task offer decoded or encoded.

use clap::{Args, Subcommand};
use proto::Site;

#[derive(Debug, Args)]
pub struct PayloadArgs {
    #[command(subcommand)]
    pub command: PayloadCommand,
}

#[derive(Debug, Subcommand)]
pub enum PayloadCommand {
    /// Decode a payload such as `011010` into an offer (JSON on stdout).
    Decode {
        /// Six binary digits `ss qq cc`, b1 first.
        bits: String,
    },
    /// Encode an offer into its six binary digits.
    Encode {
        /// Site `A` or `B` (or its id, 1 or 2).
        #[arg(long)]
        site: Site,
        /// Quality, 0–3 (0 withdraws the offer).
        #[arg(long)]
        quality: u8,
        /// Capacity, 0–3 (0 withdraws the offer).
        #[arg(long)]
        capacity: u8,
    },
}
