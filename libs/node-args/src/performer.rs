//! `performer-node`'s own arguments.

use proto::FrameCheck;

use crate::ArgList;

/// The performer process of a session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::Args)]
pub struct PerformerArgs {
    /// The check every frame carries after its payload, flown as bit symbols before END.
    #[arg(long, value_enum, default_value_t = FrameCheck::None)]
    pub frame_check: FrameCheck,
}

impl PerformerArgs {
    /// The arguments that reproduce these (none for the paper's frame, so its compose lines
    /// stay as they were).
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .opt(
                "--frame-check",
                (self.frame_check != FrameCheck::None).then_some(self.frame_check),
            )
            .done()
    }
}
