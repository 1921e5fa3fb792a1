//! The `%` header that Prophesee's formats (EVT 2.0 and 3.0 `.raw`, DAT) start with: ASCII lines
//! `% key value`, ending with a `% end` line, or, as cameras and Metavision write it, before
//! the first byte that starts no `%` line.

/// A parsed header: its `key value` lines in file order and where the data starts.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct PercentHeader {
    pub lines: Vec<(String, String)>,
    pub data_at: usize,
}

impl PercentHeader {
    /// The value of the first line whose key is `key` (keys compare without case: DAT writes
    /// `Width`, EVT `width`).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.lines
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    }

    /// `width`×`height` from a `geometry WxH` line, or from `format NAME;width=W;height=H`, or
    /// from `Width` and `Height` lines.
    pub fn geometry(&self) -> Option<(u16, u16)> {
        if let Some(format) = self.get("format") {
            let field = |name: &str| {
                format.split(';').find_map(|f| {
                    f.strip_prefix(name)
                        .and_then(|v| v.strip_prefix('='))
                        .and_then(|v| v.trim().parse::<u16>().ok())
                })
            };
            if let (Some(w), Some(h)) = (field("width"), field("height")) {
                return Some((w, h));
            }
        }
        if let Some((Ok(w), Ok(h))) = self
            .get("geometry")
            .and_then(|g| g.trim().split_once('x'))
            .map(|(w, h)| (w.parse(), h.parse()))
        {
            return Some((w, h));
        }
        match (
            self.get("width")?.trim().parse(),
            self.get("height")?.trim().parse(),
        ) {
            (Ok(w), Ok(h)) => Some((w, h)),
            _ => None,
        }
    }
}

/// Reads the `%` lines at the start of `bytes` (none is an empty header at byte 0). Errors say
/// which line is bad.
pub(crate) fn percent_header(bytes: &[u8]) -> Result<PercentHeader, String> {
    let mut header = PercentHeader::default();
    let mut pos = 0;
    while bytes.get(pos) == Some(&b'%') {
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|n| pos + n)
            .ok_or_else(|| format!("line at byte {pos} has no end"))?;
        let line = std::str::from_utf8(&bytes[pos + 1..end])
            .map_err(|_| format!("line at byte {pos} is not text"))?
            .trim();
        pos = end + 1;
        if line == "end" {
            break;
        }
        let (key, value) = line.split_once(' ').unwrap_or((line, ""));
        header
            .lines
            .push((key.to_string(), value.trim().to_string()));
    }
    header.data_at = pos;
    Ok(header)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_end_at_end_or_at_the_data() {
        let h = percent_header(b"% evt 3.0\n% geometry 640x480\n% end\n%\x01").unwrap();
        assert_eq!(h.data_at, 35);
        assert_eq!(h.geometry(), Some((640, 480)));
        let h = percent_header(b"% Height 720\n% Width 1280\n\x0c\x08").unwrap();
        assert_eq!((h.data_at, h.geometry()), (26, Some((1280, 720))));
        let h = percent_header(b"% format EVT3;height=320;width=320\n\x00").unwrap();
        assert_eq!(h.geometry(), Some((320, 320)));
        assert_eq!(percent_header(b"\x00\x01").unwrap().data_at, 0);
        assert!(percent_header(b"% evt 3.0").unwrap_err().contains("byte 0"));
    }
}
