//! `waggle allocate`: the local allocation policy run on a set of offers.

use clap::Args;
use proto::Offer;

#[derive(Debug, Args)]
pub struct AllocateArgs {
    /// Number of observers (homes from the default scene).
    #[arg(long)]
    pub observers: usize,
    /// Offers as six-bit payloads, comma separated, one each for A and B (e.g. `011010,100111`).
    #[arg(long, value_delimiter = ',', required = true)]
    pub offers: Vec<Offer>,
}
