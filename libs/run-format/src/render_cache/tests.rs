use super::*;
use proto::PixelRect;

fn rect(x: u16, y: u16, width: u16, height: u16) -> PixelRect {
    PixelRect {
        x,
        y,
        width,
        height,
    }
}

/// A 4×2 camera: a whole frame, nothing, then a 3×1 rectangle.
fn entry() -> CacheEntry<Vec<u32>> {
    let frame = vec![5u8; 3 * 4 * 2];
    let changes = [
        (FrameChange::All, frame.clone()),
        (FrameChange::Nothing, vec![]),
        (FrameChange::Within(rect(1, 1, 3, 1)), vec![7; 9]),
    ];
    let track = TrackMeta {
        frame_len: frame.len(),
        width: 4,
        updates: changes
            .iter()
            .enumerate()
            .map(|(k, (c, p))| (k as u64 * 10, *c, p.len()))
            .collect(),
    };
    CacheEntry {
        meta: Meta {
            format: FORMAT.into(),
            key: "k".into(),
            spec: "spec".into(),
            provenance: Provenance {
                version: "v".into(),
                cpu: "c".into(),
                renderer: "r".into(),
            },
            ideal: vec![1, 2],
            sim_ns: 40,
            performer_max_tracking_error_m: 0.1,
            contact_steps: 0,
            tracks: vec![track],
        },
        pixels: vec![changes.into_iter().map(|(_, p)| p).collect()],
    }
}

fn reseal(mut bytes: Vec<u8>) -> Vec<u8> {
    let body = bytes.len() - DIGEST_LEN;
    let digest = Sha256::digest(&bytes[..body]);
    bytes[body..].copy_from_slice(&digest);
    bytes
}

#[test]
fn an_entry_decodes_to_what_was_encoded_and_encodes_to_the_same_bytes() {
    let e = entry();
    let bytes = e.encode().unwrap();
    assert_eq!(&bytes[..8], MAGIC);
    let want = EntryFor {
        key: "k",
        observers: 1,
    };
    let back = decode::<Vec<u32>>(&bytes, Some(want)).unwrap();
    assert_eq!(back, e);
    assert_eq!(back.encode().unwrap(), bytes);
    let other = EntryFor {
        key: "other",
        observers: 1,
    };
    let err = decode::<Vec<u32>>(&bytes, Some(other)).unwrap_err();
    assert_eq!(err.to_string(), "it holds entry k");
    let two = EntryFor {
        key: "k",
        observers: 2,
    };
    let err = decode::<Vec<u32>>(&bytes, Some(two)).unwrap_err();
    assert_eq!(err.to_string(), "1 tracks for 2 observers");
}

#[test]
fn damaged_entries_are_refused_with_a_reason() {
    let good = entry().encode().unwrap();
    let meta_len = u64::from_le_bytes(good[8..16].try_into().unwrap());
    let huge_meta = |b: &mut Vec<u8>| b[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
    let long_pixels = move |b: &mut Vec<u8>| {
        let json = String::from_utf8(b[16..16 + meta_len as usize].to_vec()).unwrap();
        let j = json.replace(
            "\"width\":3,\"height\":1}},9]",
            "\"width\":3,\"height\":1}},99]",
        );
        assert_ne!(j, json);
        b.splice(16..16 + meta_len as usize, j.bytes());
        let n = j.len() as u64;
        b[8..16].copy_from_slice(&n.to_le_bytes());
    };
    // A frame claiming the whole address space, all of it due as the first render's pixels.
    let huge_frame = move |b: &mut Vec<u8>| {
        let json = String::from_utf8(b[16..16 + meta_len as usize].to_vec()).unwrap();
        let max = u64::MAX / 3 * 3;
        let j = json
            .replace(
                "\"frame_len\":24,\"width\":4",
                &format!("\"frame_len\":{max},\"width\":1"),
            )
            .replace("[0,\"All\",24]", &format!("[0,\"All\",{max}]"));
        assert_ne!(j, json);
        b.splice(16..16 + meta_len as usize, j.bytes());
        b[8..16].copy_from_slice(&(j.len() as u64).to_le_bytes());
    };
    type Damage = Box<dyn Fn(&mut Vec<u8>)>;
    let cases: [(Damage, bool, &str); 8] = [
        (
            Box::new(|b| b.clear()),
            false,
            "shorter than an entry's header",
        ),
        (Box::new(|b| b[0] = b'X'), false, "not a render cache entry"),
        (
            Box::new(|b| b[20] ^= 1),
            false,
            "its SHA-256 does not match",
        ),
        (
            Box::new(huge_meta),
            true,
            "its metadata length runs past its end",
        ),
        (Box::new(|b| b[17] = b'!'), true, "its metadata: "),
        (Box::new(long_pixels), true, "are due"),
        (Box::new(huge_frame), true, "pixels run past the end"),
        (
            Box::new(|b| b.insert(b.len() - DIGEST_LEN, 0)),
            true,
            "1 bytes after the last",
        ),
    ];
    for (damage, sealed, says) in cases {
        let mut bytes = good.clone();
        damage(&mut bytes);
        if sealed {
            bytes = reseal(bytes);
        }
        let err = decode::<Vec<u32>>(&bytes, None).unwrap_err();
        let chain = std::iter::successors(Some(&err as &dyn std::error::Error), |e| e.source())
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(": ");
        assert!(chain.contains(says), "{says}: {chain}");
    }
}

#[test]
fn renders_that_do_not_fit_their_frame_are_refused() {
    let m = entry().meta.tracks.remove(0);
    for (k, &(_, c, len)) in m.updates.iter().enumerate() {
        check_update(&m, k, c, len).unwrap();
    }
    let cases = [
        (1, FrameChange::Within(rect(2, 0, 3, 1)), 9, "outside"),
        (1, FrameChange::Within(rect(0, 1, 1, 2)), 6, "outside"),
        (1, FrameChange::Within(rect(0, 0, 1, 1)), 4, "are due"),
        (1, FrameChange::All, 3, "are due"),
        (1, FrameChange::Nothing, 1, "are due"),
        (0, FrameChange::Nothing, 0, "not whole"),
    ];
    for (k, change, len, says) in cases {
        let err = check_update(&m, k, change, len).unwrap_err().to_string();
        assert!(err.contains(says), "{change:?} {len}: {err}");
    }
    for (frame_len, width) in [(10, 4), (0, 0), (6, usize::MAX)] {
        let crooked = TrackMeta {
            frame_len,
            width,
            updates: vec![],
        };
        let err = check_update(&crooked, 0, FrameChange::All, frame_len).unwrap_err();
        assert!(matches!(err, CachedRenderError::Rows { .. }), "{err}");
    }
}
