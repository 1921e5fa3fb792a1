//! Certificate and key loading (`libs/bus`): an institution's CA certificate and private key in
//! PEM, as `waggle compose --ca-cert --ca-key` reads them ([`bus::tls::ExistingCa::from_pem`],
//! the checks of `ExistingCa::read` once the files are read).
//!
//! The fuzzer's bytes are the certificate's text, a NUL byte, then the key's text. A pair that
//! is accepted must be accepted again with its certificate's DER printed as PEM afresh and with
//! its key printed again by the key's own writer, with the same validity; and it must issue a
//! session's certificate whose issuer is the CA's subject.

use std::path::Path;
use std::time::Duration;

use bus::tls::ExistingCa;
use x509_parser::pem::parse_x509_pem;

/// The "now" a CA's expiry is checked against (2026-01-01T00:00:00Z): fixed, so that an input
/// gives the same outcome on every run.
pub const NOW_UNIX_S: i64 = 1_767_225_600;

/// The names the errors give the two files.
const PATHS: (&str, &str) = ("ca.crt", "ca.key");

/// The standard base64 alphabet.
const BASE64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// `der` as a PEM block labelled `label`, 64 base64 characters a line.
pub fn pem_text(label: &str, der: &[u8]) -> String {
    let mut b64 = Vec::with_capacity(der.len().div_ceil(3) * 4);
    for chunk in der.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for k in 0..4 {
            b64.push(if k <= chunk.len() {
                BASE64[(n >> (18 - 6 * k) & 63) as usize]
            } else {
                b'='
            });
        }
    }
    let mut out = format!("-----BEGIN {label}-----\n");
    for line in b64.chunks(64) {
        out.push_str(std::str::from_utf8(line).expect("base64 is ASCII"));
        out.push('\n');
    }
    out.push_str(&format!("-----END {label}-----\n"));
    out
}

fn load(cert: &str, key: &str) -> Result<ExistingCa, bus::BusError> {
    let paths = (Path::new(PATHS.0), Path::new(PATHS.1));
    ExistingCa::from_pem(cert.to_owned(), key.to_owned(), paths, NOW_UNIX_S)
}

/// A CA certificate's text, a NUL byte, its private key's text.
pub fn tls_pem(data: &[u8]) {
    let (cert, key) = match data.iter().position(|&b| b == 0) {
        Some(at) => (&data[..at], &data[at + 1..]),
        None => (data, &[][..]),
    };
    let (Ok(cert), Ok(key)) = (std::str::from_utf8(cert), std::str::from_utf8(key)) else {
        return;
    };
    let Ok(ca) = load(cert, key) else {
        return;
    };
    assert_eq!(ca.cert_pem(), cert, "the certificate is kept as read");
    assert!(ca.not_after_unix_s() > NOW_UNIX_S);
    let (_, pem) = parse_x509_pem(cert.as_bytes()).expect("an accepted certificate is PEM");
    let again = pem_text("CERTIFICATE", &pem.contents);
    let reprinted = load(&again, key)
        .unwrap_or_else(|e| panic!("the certificate printed again is refused: {e}\n{again}"));
    assert_eq!(reprinted.not_after_unix_s(), ca.not_after_unix_s());
    let key_pair = rcgen::KeyPair::from_pem(key).expect("an accepted key reads");
    let key_again = key_pair.serialize_pem();
    let rekeyed = load(cert, &key_again)
        .unwrap_or_else(|e| panic!("the key printed again is refused: {e}\n{key_again}"));
    assert_eq!(rekeyed.not_after_unix_s(), ca.not_after_unix_s());
    issued_by(&ca, &pem.contents);
}

/// A session's certificate issued by `ca` (its certificate's DER `ca_der`) names the CA's
/// subject as its issuer and ends no later than the CA.
fn issued_by(ca: &ExistingCa, ca_der: &[u8]) {
    let mut written = Vec::new();
    let issued = bus::tls::issue(
        "fuzz",
        &["sim".to_owned()],
        Duration::from_secs(3600),
        Some(ca),
        |path, text| {
            written.push((path.to_path_buf(), text.to_owned()));
            Ok(())
        },
        Path::new("/fuzz"),
    );
    if issued.is_err() {
        return; // rcgen refuses a CA it cannot sign with (an expired one, say): an error
    }
    let ca_cert = ca_certificate(ca_der);
    let leaf = written
        .iter()
        .find(|(p, _)| p.ends_with("sim.cert.pem"))
        .expect("the issued certificate is written");
    let (_, pem) = parse_x509_pem(leaf.1.as_bytes()).expect("an issued certificate is PEM");
    let cert = pem.parse_x509().expect("an issued certificate parses");
    assert_eq!(
        cert.issuer().as_raw(),
        ca_cert.subject().as_raw(),
        "issued under another name than the CA's"
    );
    assert!(cert.validity().not_after.timestamp() <= ca.not_after_unix_s());
}

fn ca_certificate(der: &[u8]) -> x509_parser::certificate::X509Certificate<'_> {
    use x509_parser::prelude::FromDer;
    x509_parser::certificate::X509Certificate::from_der(der)
        .expect("an accepted certificate parses")
        .1
}
