//! `waggle payload`: decode and encode six-bit task offers from the command line.

use anyhow::Context;
use commands::payload::{PayloadArgs, PayloadCommand};
use proto::{Offer, Site};
use serde::Serialize;

/// The JSON shape of a decoded offer.
#[derive(Serialize)]
struct OfferJson {
    site: Site,
    quality: u8,
    capacity: u8,
    withdrawn: bool,
}

/// The JSON line printed for `offer`.
pub fn offer_json(offer: &Offer) -> String {
    let view = OfferJson {
        site: offer.site,
        quality: offer.quality,
        capacity: offer.capacity,
        withdrawn: offer.withdrawn(),
    };
    serde_json::to_string(&view).expect("a flat struct of plain fields always serialises")
}

pub fn run(args: PayloadArgs) -> anyhow::Result<()> {
    match args.command {
        PayloadCommand::Decode { bits } => {
            let offer: Offer = bits
                .parse()
                .with_context(|| format!("invalid payload {bits:?}"))?;
            println!("{}", offer_json(&offer));
        }
        PayloadCommand::Encode {
            site,
            quality,
            capacity,
        } => {
            let offer = Offer::new(site, quality, capacity).context("invalid offer")?;
            println!("{offer}");
        }
    }
    Ok(())
}
