//! The lab's run files read back from a shared directory: per-trial record files
//! (`run_format::trial_record`), read when a study or `waggle trials` resumes and when shards
//! merge, and render cache entries (`run_format::render_cache`), read by every shard that
//! shares a cache directory.
//!
//! [`trial_record`] parses a record file as the lab does; a record that parses prints and parses
//! back to the same value, the checks accept it exactly when its digest, format and indices
//! agree, and the writer's own encoding of its trial reads back through every check.
//!
//! [`render_cache`] decodes an entry as the lab does, and the same bytes with their digest made
//! right (so that mutations reach the metadata and the pixel section): a decoded entry encodes
//! to an entry that decodes equal, and to the very same bytes when its metadata is as the
//! encoder writes it; a damaged one is refused with a reason.

use std::collections::BTreeMap;

use proto::Modality;
use run_format::link_out::ObserverOut;
use run_format::render_cache::{self, CacheEntry, DIGEST_LEN, EntryFor, RenderCacheError};
use run_format::trial_record::{
    RECORD_FORMAT, StoredTrial, TrialRecord, check, checksum, decode, encode, parse,
};

/// A per-trial record file's bytes.
pub fn trial_record(data: &[u8]) {
    let Ok(stored) = decode::<TrialRecord>(data) else {
        return;
    };
    let printed = serde_json::to_vec(&stored).expect("a parsed record prints");
    let again: StoredTrial<TrialRecord> =
        decode(&printed).unwrap_or_else(|e| panic!("a printed record is refused: {e}"));
    assert_eq!(again, stored);
    let body = &stored.body;
    let (point, index) = (body.point.clone(), body.index);
    let agrees = checksum(body).is_ok_and(|sum| sum == stored.sha256)
        && body.format == RECORD_FORMAT
        && body.record.index == index;
    let checked = check(stored.clone(), &point, index);
    assert_eq!(checked.is_ok(), agrees, "{checked:?}");
    let bytes =
        encode(&point, body.provenance.clone(), &body.record).expect("a parsed trial encodes");
    let (record, provenance) = parse::<TrialRecord>(&bytes, &point, body.record.index)
        .unwrap_or_else(|e| panic!("a record Waggle wrote is refused: {e}"));
    assert_eq!(record, body.record);
    assert_eq!(provenance, body.provenance);
}

/// The ideal receivers' output per modality and observer, as the lab keeps it.
type Ideal = BTreeMap<Modality, Vec<ObserverOut>>;

/// A render cache entry's bytes.
pub fn render_cache(data: &[u8]) {
    cache_entry(data);
    if data.len() >= DIGEST_LEN {
        use sha2::Digest;
        let mut sealed = data.to_vec();
        let body = sealed.len() - DIGEST_LEN;
        let digest = sha2::Sha256::digest(&sealed[..body]);
        sealed[body..].copy_from_slice(&digest);
        cache_entry(&sealed);
    }
}

fn cache_entry(data: &[u8]) {
    let entry = match render_cache::decode::<Ideal>(data, None) {
        Ok(entry) => entry,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    let held: usize = entry.pixels.iter().flatten().map(Vec::len).sum();
    assert!(
        held <= data.len(),
        "{held} bytes of pixels from {}",
        data.len()
    );
    let bytes = entry.encode().expect("a decoded entry encodes");
    let again: CacheEntry<Ideal> = render_cache::decode(&bytes, None)
        .unwrap_or_else(|e| panic!("an entry Waggle encoded is refused: {e}"));
    assert_eq!(again, entry);
    assert_eq!(again.encode().expect("it encodes again"), bytes);
    let meta_len = u64::from_le_bytes(data[8..16].try_into().expect("eight bytes"));
    let meta_json = serde_json::to_vec(&entry.meta).expect("its metadata prints");
    if meta_json.len() as u64 == meta_len && data[16..].starts_with(&meta_json) {
        assert_eq!(
            bytes, data,
            "an entry as the encoder writes it re-encodes differently"
        );
    }
    let (key, observers) = (entry.meta.key.as_str(), entry.meta.tracks.len());
    render_cache::decode::<Ideal>(data, Some(EntryFor { key, observers }))
        .unwrap_or_else(|e| panic!("the entry of its own key is refused: {e}"));
    let other = format!("{key}-other");
    let wrong = EntryFor {
        key: &other,
        observers,
    };
    let refused = render_cache::decode::<Ideal>(data, Some(wrong));
    assert!(
        matches!(refused, Err(RenderCacheError::Key(_))),
        "{refused:?}"
    );
}
