//! `waggle`: the Waggle launcher and user-facing command line.

use clap::Parser;

#[derive(Parser)]
#[command(name = "waggle", version, about = "Waggle: motion-mediated drone recruitment")]
enum Cli {}

fn main() -> anyhow::Result<()> {
    match Cli::parse() {}
}
