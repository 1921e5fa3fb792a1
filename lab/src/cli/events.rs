//! `waggle events convert`: PNG frames → synthetic events ([`crate::harness::decode::convert`]).

use crate::harness::decode::convert::{ConvertOptions, convert};
use commands::events::{EventsArgs, EventsCommand};

pub fn run(args: EventsArgs) -> anyhow::Result<()> {
    match args.command {
        EventsCommand::Convert(args) => {
            let summary = convert(&ConvertOptions {
                fps: args.fps,
                input: args.input,
                out: args.out,
                threshold: args.threshold,
            })?;
            println!("{summary}");
            Ok(())
        }
    }
}
