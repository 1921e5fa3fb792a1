//! `waggle allocate`: run the local allocation policy on a set of offers.
//!
//! Every observer of the default scene holding exactly these offers computes the same
//! allocation; the output maps each observer to its site or `null`.

use std::collections::BTreeMap;

use anyhow::{bail, ensure};
use commands::allocate::AllocateArgs;
use proto::allocation::offers_by_site;
use proto::scene::MAX_OBSERVERS;
use proto::{Offer, Roster, Site, allocate};

/// The allocation as a JSON object `{"O1": "A", …}` with `null` for unassigned observers.
pub fn allocation_json(n_observers: usize, offers: &[Offer]) -> anyhow::Result<String> {
    ensure!(
        (1..=MAX_OBSERVERS).contains(&n_observers),
        "--observers must be between 1 and {MAX_OBSERVERS}, got {n_observers}"
    );
    let by_site = offers_by_site(offers)?;
    let missing: Vec<&str> = Site::ALL
        .iter()
        .filter(|s| !by_site.contains_key(s))
        .map(|s| s.name())
        .collect();
    if !missing.is_empty() {
        bail!(
            "observers allocate only once they hold offers for both A and B; missing {}",
            missing.join(" and ")
        );
    }
    let allocation = allocate(&by_site, &Roster::default_scene(n_observers));
    // Observer names O1…O8 sort in roster order.
    let view: BTreeMap<String, Option<Site>> = allocation
        .into_iter()
        .map(|(o, s)| (o.to_string(), s))
        .collect();
    Ok(serde_json::to_string(&view)?)
}

pub fn run(args: AllocateArgs) -> anyhow::Result<()> {
    println!("{}", allocation_json(args.observers, &args.offers)?);
    Ok(())
}
