//! The lab's run files read back from a shared directory: per-trial record files
//! (`run_format::trial_record`), read when a study or `waggle trials` resumes and when shards
//! merge.
//!
//! [`trial_record`] parses a record file as the lab does; a record that parses prints and parses
//! back to the same value, the checks accept it exactly when its digest, format and indices
//! agree, and the writer's own encoding of its trial reads back through every check.

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
