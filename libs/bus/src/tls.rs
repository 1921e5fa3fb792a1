//! Per-session certificates for Zenoh's `quic/` links (mutual TLS).
//!
//! Beside the passwords (see [`crate::auth`]), each session gets its own certificate authority
//! and one certificate per process (common name: the process's user name, e.g. `camera-O1`) plus
//! one for the router. The CA's private key is never written: once the session's certificates are
//! issued nobody can mint another, and a certificate of another session (another CA) is refused
//! by every link. Certificates expire with the session (`valid_for`; Zenoh closes a link whose
//! certificate expires). Files, all private (0600) in the secrets directory: `ca.pem`,
//! `<user>.cert.pem`, `<user>.key.pem`.
//!
//! Only `quic/` endpoints use them: Zenoh 1.10.2's `tls/` link is unsound
//! (eclipse-zenoh/zenoh#2557), and loopback TCP needs no encryption.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose, PublicKeyData, SanType,
};

use crate::error::BusError;

/// The router's certificate name (the router has no password: it checks the others').
pub const ROUTER_CERT_NAME: &str = "router";

/// The session CA's certificate file in a secrets directory.
pub const CA_FILE: &str = "ca.pem";

/// The certificate and key files of `name` in a secrets directory.
pub fn cert_files(dir: &Path, name: &str) -> TlsFiles {
    TlsFiles {
        ca: dir.join(CA_FILE),
        cert: dir.join(format!("{name}.cert.pem")),
        key: dir.join(format!("{name}.key.pem")),
    }
}

/// One process's TLS files: the session CA, its certificate and its private key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    pub ca: PathBuf,
    pub cert: PathBuf,
    pub key: PathBuf,
}

impl TlsFiles {
    /// True when all three files exist.
    pub fn exist(&self) -> bool {
        [&self.ca, &self.cert, &self.key]
            .iter()
            .all(|p| p.is_file())
    }
}

fn tls_err(what: &str, e: impl std::fmt::Display) -> BusError {
    BusError::Credentials(format!("certificates: {what}: {e}"))
}

/// An existing certificate authority (an institution's) that issues a session's certificates
/// instead of a CA of the session's own. Its certificate becomes the session's `ca.pem`; its key
/// signs and is never copied.
#[derive(Clone)]
pub struct ExistingCa {
    cert_pem: String,
    key_pem: String,
    not_after_unix_s: i64,
}

impl std::fmt::Debug for ExistingCa {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ExistingCa {{ key: *** }}")
    }
}

impl ExistingCa {
    /// Reads a CA certificate and its private key (PEM), refusing a key file other users may
    /// read, a certificate that is no CA or has expired, and a key that is not the
    /// certificate's.
    pub fn read(cert: &Path, key: &Path) -> Result<Self, BusError> {
        use std::os::unix::fs::PermissionsExt;
        let bad = |path: &Path, why: String| ca_err(path, &why);
        let cert_pem = std::fs::read_to_string(cert).map_err(|e| bad(cert, e.to_string()))?;
        let mode = std::fs::metadata(key)
            .map_err(|e| bad(key, e.to_string()))?
            .permissions()
            .mode();
        if mode & 0o077 != 0 {
            return Err(bad(
                key,
                format!(
                    "readable by other users (mode {:o}): chmod go-rwx it",
                    mode & 0o777
                ),
            ));
        }
        let key_pem = std::fs::read_to_string(key).map_err(|e| bad(key, e.to_string()))?;
        let now_unix_s = time::OffsetDateTime::now_utc().unix_timestamp();
        Self::from_pem(cert_pem, key_pem, (cert, key), now_unix_s)
    }

    /// The checks of [`ExistingCa::read`] on texts already read, with no file system: the key
    /// is a private key in PEM, the certificate a PEM X.509 CA certificate whose public key is
    /// the key's and that is still valid at `now_unix_s`. `paths` (certificate, key) only name
    /// the files in the errors.
    pub fn from_pem(
        cert_pem: String,
        key_pem: String,
        paths: (&Path, &Path),
        now_unix_s: i64,
    ) -> Result<Self, BusError> {
        let (cert, key) = paths;
        let bad = |path: &Path, why: String| ca_err(path, &why);
        let key_pair = KeyPair::from_pem(&key_pem)
            .map_err(|e| bad(key, format!("not a private key in PEM: {e}")))?;
        let (_, pem) = x509_parser::pem::parse_x509_pem(cert_pem.as_bytes())
            .map_err(|e| bad(cert, format!("not a PEM certificate: {e}")))?;
        let parsed = pem
            .parse_x509()
            .map_err(|e| bad(cert, format!("not an X.509 certificate: {e}")))?;
        if !parsed.is_ca() {
            return Err(bad(
                cert,
                "not a CA certificate (no basicConstraints CA:TRUE)".into(),
            ));
        }
        if parsed.public_key().raw != key_pair.subject_public_key_info().as_slice() {
            return Err(bad(
                key,
                format!("not the key of the CA certificate {}", cert.display()),
            ));
        }
        let not_after_unix_s = parsed.validity().not_after.timestamp();
        if not_after_unix_s <= now_unix_s {
            return Err(bad(cert, "expired".into()));
        }
        encodable_name(parsed.subject()).map_err(|why| bad(cert, why))?;
        names_itself_as_issuer(&cert_pem, key_pair, parsed.subject().as_raw())
            .map_err(|why| bad(cert, why))?;
        Ok(Self {
            cert_pem,
            key_pem,
            not_after_unix_s,
        })
    }

    /// The CA certificate's PEM text, as read (it becomes a session's `ca.pem`).
    pub fn cert_pem(&self) -> &str {
        &self.cert_pem
    }

    /// The end of the CA certificate's validity, in Unix seconds.
    pub fn not_after_unix_s(&self) -> i64 {
        self.not_after_unix_s
    }
}

/// Checks that every attribute type of `name` is an object identifier DER can encode (first
/// arc 0–2, second below 40 under 0 and 1, and 80 plus the second within 64 bits): rcgen writes the CA's subject into each certificate
/// it issues, and its encoder panics on one it cannot encode. A parser reads such an identifier
/// from a first byte of 120 or more split naively (205 as 5.5).
fn encodable_name(name: &x509_parser::x509::X509Name<'_>) -> Result<(), String> {
    for attr in name.iter_attributes() {
        let oid = attr.attr_type();
        let arcs: Option<Vec<u64>> = oid.iter().map(|arcs| arcs.take(2).collect());
        let encodable = match arcs.as_deref() {
            Some(&[first, second]) => match first {
                0 | 1 => second < 40,
                2 => second <= u64::MAX - 81, // 80 + second must fit the encoder's u64
                _ => false,
            },
            _ => false,
        };
        if !encodable {
            return Err(format!(
                "its subject name has an attribute type that cannot be encoded again ({oid})"
            ));
        }
    }
    Ok(())
}

/// Checks that a certificate issued under the CA names the CA's subject, byte for byte, as its
/// issuer. rcgen rebuilds the issuer's name from the parsed subject, so a subject it cannot
/// rebuild as read (bytes outside its attributes, an attribute it drops) would make every
/// session certificate name another issuer, and peers would refuse the chain only at the
/// handshake, far from the file at fault. One throwaway certificate is signed to see.
fn names_itself_as_issuer(cert_pem: &str, key: KeyPair, subject_der: &[u8]) -> Result<(), String> {
    let issuer = Issuer::from_ca_cert_pem(cert_pem, key)
        .map_err(|e| format!("cannot issue under it: {e}"))?;
    let probe_key = KeyPair::generate().map_err(|e| format!("cannot issue under it: {e}"))?;
    let probe = CertificateParams::new(vec!["probe".to_owned()])
        .and_then(|p| p.signed_by(&probe_key, &issuer))
        .map_err(|e| format!("cannot issue under it: {e}"))?;
    let (_, probe) = x509_parser::parse_x509_certificate(probe.der())
        .map_err(|e| format!("a certificate issued under it does not parse: {e}"))?;
    if probe.issuer().as_raw() != subject_der {
        return Err(
            "its subject name does not encode as read (bytes outside its attributes, \
                    or an attribute that cannot be rebuilt): certificates issued under it \
                    would name another issuer"
                .into(),
        );
    }
    Ok(())
}

/// A refusal of an existing CA's file `path`.
fn ca_err(path: &Path, why: &str) -> BusError {
    BusError::Credentials(format!("the CA {}: {why}", path.display()))
}

/// Issues a certificate for each of `names` into `dir` through `write` (which writes one
/// private file), valid from a minute ago for `valid_for` (and never beyond the CA), signed by
/// `existing` or else by a new session CA whose key is never written.
pub fn issue(
    session_label: &str,
    names: &[String],
    valid_for: Duration,
    existing: Option<&ExistingCa>,
    mut write: impl FnMut(&Path, &str) -> Result<(), BusError>,
    dir: &Path,
) -> Result<(), BusError> {
    let now = time::OffsetDateTime::now_utc();
    let not_before = now - time::Duration::minutes(1);
    let mut not_after =
        now + time::Duration::try_from(valid_for).map_err(|e| tls_err("validity", e))?;
    let issuer = match existing {
        Some(ca) => {
            let ca_end = time::OffsetDateTime::from_unix_timestamp(ca.not_after_unix_s)
                .map_err(|e| tls_err("CA validity", e))?;
            not_after = not_after.min(ca_end);
            write(&dir.join(CA_FILE), &ca.cert_pem)?;
            let key = KeyPair::from_pem(&ca.key_pem).map_err(|e| tls_err("CA key", e))?;
            Issuer::from_ca_cert_pem(&ca.cert_pem, key).map_err(|e| tls_err("CA", e))?
        }
        None => new_session_ca(session_label, not_before, not_after, &mut write, dir)?,
    };
    issue_each(names, &issuer, not_before, not_after, write, dir)
}

/// A new CA for one session: its certificate written as `ca.pem`, its key kept in memory only.
fn new_session_ca(
    session_label: &str,
    not_before: time::OffsetDateTime,
    not_after: time::OffsetDateTime,
    write: &mut impl FnMut(&Path, &str) -> Result<(), BusError>,
    dir: &Path,
) -> Result<Issuer<'static, KeyPair>, BusError> {
    let ca_key = KeyPair::generate().map_err(|e| tls_err("CA key", e))?;
    let mut ca = CertificateParams::new(Vec::<String>::new()).map_err(|e| tls_err("CA", e))?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca.distinguished_name.push(
        DnType::CommonName,
        format!("waggle session {session_label} CA"),
    );
    ca.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    ca.not_before = not_before;
    ca.not_after = not_after;
    let ca_cert = ca.self_signed(&ca_key).map_err(|e| tls_err("CA", e))?;
    write(&dir.join(CA_FILE), &ca_cert.pem())?;
    Ok(Issuer::new(ca, ca_key))
}

/// One certificate and key per name, signed by `issuer`.
fn issue_each(
    names: &[String],
    issuer: &Issuer<'static, KeyPair>,
    not_before: time::OffsetDateTime,
    not_after: time::OffsetDateTime,
    mut write: impl FnMut(&Path, &str) -> Result<(), BusError>,
    dir: &Path,
) -> Result<(), BusError> {
    for name in names {
        let key = KeyPair::generate().map_err(|e| tls_err(name, e))?;
        let mut p = CertificateParams::new(vec!["localhost".to_string(), name.clone()])
            .map_err(|e| tls_err(name, e))?;
        p.subject_alt_names
            .push(SanType::IpAddress(std::net::Ipv4Addr::LOCALHOST.into()));
        p.distinguished_name.push(DnType::CommonName, name.clone());
        p.key_usages = vec![
            KeyUsagePurpose::DigitalSignature,
            KeyUsagePurpose::KeyEncipherment,
        ];
        p.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        p.not_before = not_before;
        p.not_after = not_after;
        let cert = p.signed_by(&key, issuer).map_err(|e| tls_err(name, e))?;
        let files = cert_files(dir, name);
        write(&files.cert, &cert.pem())?;
        write(&files.key, &key.serialize_pem())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn a_session_gets_a_ca_and_one_certificate_and_key_per_name() {
        let mut files: BTreeMap<PathBuf, String> = BTreeMap::new();
        let dir = Path::new("/nowhere");
        issue(
            "s1",
            &["camera-O1".to_string(), ROUTER_CERT_NAME.to_string()],
            Duration::from_secs(3600),
            None,
            |p, text| {
                files.insert(p.to_path_buf(), text.to_string());
                Ok(())
            },
            dir,
        )
        .unwrap();
        let names: Vec<String> = files
            .keys()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "ca.pem",
                "camera-O1.cert.pem",
                "camera-O1.key.pem",
                "router.cert.pem",
                "router.key.pem"
            ]
        );
        assert!(files[&dir.join("ca.pem")].starts_with("-----BEGIN CERTIFICATE-----"));
        assert!(files[&dir.join("router.key.pem")].contains("PRIVATE KEY"));
        // Two sessions never share a CA.
        let mut other = String::new();
        issue(
            "s2",
            &[],
            Duration::from_secs(60),
            None,
            |p, t| {
                if p.ends_with(CA_FILE) {
                    other = t.to_string();
                }
                Ok(())
            },
            dir,
        )
        .unwrap();
        assert_ne!(other, files[&dir.join("ca.pem")]);
    }
}
