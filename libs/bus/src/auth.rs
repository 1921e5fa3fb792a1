//! Per-session credentials: every process of a run authenticates to the session's router with
//! its own user name and a random password (Zenoh's user/password authentication, an HMAC
//! challenge: the password never crosses the link).
//!
//! The launcher creates the secrets in a private directory (mode 0700, files 0600) outside the
//! run directory, hands each child only the path of its own file (`--credentials FILE`: a path
//! on the command line, never the secret), and removes the directory when the run ends. The
//! router reads the dictionary of every user from the same directory.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use crate::error::BusError;
use crate::tls::{self, TlsFiles};

/// How long a session's certificates are valid: a run or a study shard ends well within it.
pub const CERTIFICATE_VALIDITY: std::time::Duration = std::time::Duration::from_secs(7 * 24 * 3600);

/// One process's user name and password.
#[derive(Clone, PartialEq, Eq)]
pub struct Credentials {
    pub user: String,
    password: String,
    /// The certificate files beside the credentials file (`quic/` links), when the session
    /// has them.
    pub tls: Option<TlsFiles>,
}

impl std::fmt::Debug for Credentials {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Credentials {{ user: {:?}, password: *** }}", self.user)
    }
}

impl Credentials {
    /// Reads a credentials file (`user:password` on one line).
    pub fn read(path: &Path) -> Result<Self, BusError> {
        let bad = |why: &str| {
            BusError::Credentials(format!("credentials file {}: {why}", path.display()))
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(&e.to_string()))?;
        let line = text.trim();
        let (user, password) = line
            .split_once(':')
            .ok_or_else(|| bad("not user:password"))?;
        if user.is_empty() || password.is_empty() || password.contains(char::is_whitespace) {
            return Err(bad("empty user or password"));
        }
        let tls = path
            .parent()
            .map(|dir| tls::cert_files(dir, user))
            .filter(TlsFiles::exist);
        Ok(Self {
            user: user.to_string(),
            password: password.to_string(),
            tls,
        })
    }

    pub(crate) fn password(&self) -> &str {
        &self.password
    }
}

/// A random password: 32 hex digits from the kernel's CSPRNG.
fn random_password() -> Result<String, BusError> {
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| BusError::Credentials(format!("reading /dev/urandom: {e}")))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// The secrets of one session: a launcher's own are removed from disk when dropped; those
/// written beside a compose file ([`SessionSecrets::create_kept`]) stay, to be copied to every
/// host of the session.
#[derive(Debug)]
pub struct SessionSecrets {
    dir: PathBuf,
    dictionary: PathBuf,
    files: BTreeMap<String, PathBuf>,
    remove_on_drop: bool,
}

/// Name prefix of the launchers' own secrets directories.
const OWNED_PREFIX: &str = "waggle-secrets-";
/// The file naming the process that owns a launcher's secrets directory.
const OWNER_FILE: &str = "owner.pid";

/// The name of a process's credentials file.
fn credentials_file_name(user: &str) -> String {
    format!("{user}.credentials")
}

fn write_private(path: &Path, text: &str) -> Result<(), BusError> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .map_err(|e| BusError::Credentials(format!("creating {}: {e}", path.display())))?;
    f.write_all(text.as_bytes())
        .map_err(|e| BusError::Credentials(format!("writing {}: {e}", path.display())))
}

/// The share of the session router's dictionary a host's copy of the secrets holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DictionaryShare<'a> {
    /// None: the host runs no router.
    None,
    /// All of it, with the router's certificate: the session router's host.
    Whole,
    /// Only these users' entries: a site router's host, which checks the processes of the
    /// hosts it serves (it presents its own launcher's certificate).
    Of(&'a [String]),
}

/// The dictionary's file name in a secrets directory.
const DICTIONARY_FILE: &str = "dictionary";

impl SessionSecrets {
    /// Creates a password for each of `users` under `parent/waggle-secrets-<session>`, removed
    /// when dropped. The directory names its owner (`owner.pid`), so that one left by a
    /// launcher that was killed outright (SIGKILL: no drop) is removed by the next
    /// ([`SessionSecrets::remove_stale`]).
    pub fn create(parent: &Path, session: &str, users: &[String]) -> Result<Self, BusError> {
        let mut out = Self::create_kept(&parent.join(format!("{OWNED_PREFIX}{session}")), users)?;
        out.remove_on_drop = true;
        write_private(
            &out.dir.join(OWNER_FILE),
            &format!("{}\n", std::process::id()),
        )?;
        Ok(out)
    }

    /// Removes the secrets directories under `parent` whose owning launcher is gone (its
    /// `owner.pid` names no live process); returns how many. Directories without an owner
    /// file, or that cannot be read or removed, are left alone.
    pub fn remove_stale(parent: &Path) -> usize {
        let Ok(entries) = std::fs::read_dir(parent) else {
            return 0;
        };
        let mut removed = 0;
        for entry in entries.flatten() {
            let dir = entry.path();
            let owned = entry
                .file_name()
                .to_str()
                .is_some_and(|n| n.starts_with(OWNED_PREFIX));
            if !owned || !dir.is_dir() {
                continue;
            }
            let owner = std::fs::read_to_string(dir.join(OWNER_FILE))
                .ok()
                .and_then(|t| t.trim().parse::<u32>().ok());
            let Some(pid) = owner else { continue };
            let alive = Path::new("/proc").join(pid.to_string()).exists();
            if !alive && std::fs::remove_dir_all(&dir).is_ok() {
                removed += 1;
            }
        }
        removed
    }

    /// Creates a password for each of `users` in directory `dir` (replaced if it exists), kept
    /// when dropped.
    pub fn create_kept(dir: &Path, users: &[String]) -> Result<Self, BusError> {
        Self::create_kept_valid_for(dir, users, CERTIFICATE_VALIDITY)
    }

    /// [`SessionSecrets::create_kept`] with certificates valid for `validity` from now.
    pub fn create_kept_valid_for(
        dir: &Path,
        users: &[String],
        validity: std::time::Duration,
    ) -> Result<Self, BusError> {
        Self::create_kept_signed_by(dir, users, validity, None)
    }

    /// [`SessionSecrets::create_kept_valid_for`] with certificates issued by `ca` (an
    /// institution's) instead of a new session CA, and valid no longer than it.
    pub fn create_kept_signed_by(
        dir: &Path,
        users: &[String],
        validity: std::time::Duration,
        ca: Option<&tls::ExistingCa>,
    ) -> Result<Self, BusError> {
        let dir = dir.to_path_buf();
        let io = |what: &str, e: std::io::Error| {
            BusError::Credentials(format!("{what} {}: {e}", dir.display()))
        };
        if dir.exists() {
            std::fs::remove_dir_all(&dir).map_err(|e| io("removing the stale", e))?;
        }
        std::fs::create_dir_all(&dir).map_err(|e| io("creating", e))?;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))
            .map_err(|e| io("protecting", e))?;
        let mut out = Self {
            dictionary: dir.join(DICTIONARY_FILE),
            dir,
            files: BTreeMap::new(),
            remove_on_drop: false,
        };
        let mut dictionary = String::new();
        for user in users {
            if user.is_empty() || user.contains([':', '/', '\n']) {
                return Err(BusError::Credentials(format!("user name {user:?}")));
            }
            let password = random_password()?;
            let file = out.dir.join(credentials_file_name(user));
            write_private(&file, &format!("{user}:{password}\n"))?;
            dictionary.push_str(&format!("{user}:{password}\n"));
            out.files.insert(user.clone(), file);
        }
        write_private(&out.dictionary, &dictionary)?;
        let label = out
            .dir
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let mut names = users.to_vec();
        names.push(tls::ROUTER_CERT_NAME.to_string());
        tls::issue(&label, &names, validity, ca, write_private, &out.dir)?;
        Ok(out)
    }

    /// Opens the secrets kept in `dir` for `users` (those a host needs; the router's host also
    /// needs the dictionary). Refuses a directory or file other users may read, like ssh.
    pub fn open(dir: &Path, users: &[String]) -> Result<Self, BusError> {
        let bad = |why: String| {
            BusError::Credentials(format!("session secrets {}: {why}", dir.display()))
        };
        let private = |path: &Path| -> Result<(), BusError> {
            let mode = std::fs::metadata(path)
                .map_err(|e| bad(format!("{}: {e}", path.display())))?
                .permissions()
                .mode();
            if mode & 0o077 != 0 {
                return Err(bad(format!(
                    "{} is readable by other users (mode {:o}): chmod go-rwx it",
                    path.display(),
                    mode & 0o777
                )));
            }
            Ok(())
        };
        private(dir)?;
        let mut files = BTreeMap::new();
        for user in users {
            let file = dir.join(credentials_file_name(user));
            private(&file)?;
            Credentials::read(&file)?;
            files.insert(user.clone(), file);
        }
        Ok(Self {
            dictionary: dir.join(DICTIONARY_FILE),
            dir: dir.to_path_buf(),
            files,
            remove_on_drop: false,
        })
    }

    /// Copies the credentials this holds (and the share of the router's dictionary `dictionary`
    /// names) into a new private directory `dir`, which must not exist: what one host needs and
    /// no more, so a host never holds another host's passwords (a site's router holds those of
    /// the hosts it serves: it checks them).
    pub fn export(&self, dir: &Path, dictionary: DictionaryShare<'_>) -> Result<Self, BusError> {
        let io = |what: &str, path: &Path, e: std::io::Error| {
            BusError::Credentials(format!("{what} {}: {e}", path.display()))
        };
        if dir.exists() {
            return Err(BusError::Credentials(format!(
                "{} exists already: name a new directory",
                dir.display()
            )));
        }
        std::fs::create_dir_all(dir).map_err(|e| io("creating", dir, e))?;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))
            .map_err(|e| io("protecting", dir, e))?;
        let copy = |from: &Path| -> Result<PathBuf, BusError> {
            let name = from.file_name().ok_or_else(|| {
                BusError::Credentials(format!("{} has no file name", from.display()))
            })?;
            let to = dir.join(name);
            let text = std::fs::read_to_string(from).map_err(|e| io("reading", from, e))?;
            write_private(&to, &text)?;
            Ok(to)
        };
        let mut files = BTreeMap::new();
        // Certificates go with what they authenticate: each user's own, the router's with the
        // dictionary, the CA's to everyone (sessions made before certificates have none).
        let copy_tls = |name: &str| -> Result<(), BusError> {
            let t = tls::cert_files(&self.dir, name);
            if t.exist() {
                for f in [&t.cert, &t.key] {
                    copy(f)?;
                }
                if !dir.join(tls::CA_FILE).exists() {
                    copy(&t.ca)?;
                }
            }
            Ok(())
        };
        for (user, file) in &self.files {
            files.insert(user.clone(), copy(file)?);
            copy_tls(user)?;
        }
        match dictionary {
            DictionaryShare::None => {}
            DictionaryShare::Whole => {
                self.check_dictionary()?;
                copy(&self.dictionary)?;
                copy_tls(tls::ROUTER_CERT_NAME)?;
            }
            DictionaryShare::Of(users) => {
                self.check_dictionary()?;
                let text = std::fs::read_to_string(&self.dictionary)
                    .map_err(|e| io("reading", &self.dictionary, e))?;
                let kept: String = text
                    .lines()
                    .filter(|l| {
                        l.split_once(':')
                            .is_some_and(|(u, _)| users.iter().any(|x| x == u))
                    })
                    .map(|l| format!("{l}\n"))
                    .collect();
                write_private(&dir.join(DICTIONARY_FILE), &kept)?;
            }
        }
        Ok(Self {
            dictionary: dir.join(DICTIONARY_FILE),
            dir: dir.to_path_buf(),
            files,
            remove_on_drop: false,
        })
    }

    /// Checks the router's dictionary is there and private.
    pub fn check_dictionary(&self) -> Result<(), BusError> {
        let mode = std::fs::metadata(&self.dictionary)
            .map_err(|e| {
                BusError::Credentials(format!(
                    "the router's dictionary {}: {e}",
                    self.dictionary.display()
                ))
            })?
            .permissions()
            .mode();
        if mode & 0o077 != 0 {
            return Err(BusError::Credentials(format!(
                "{} is readable by other users (mode {:o})",
                self.dictionary.display(),
                mode & 0o777
            )));
        }
        Ok(())
    }

    /// The credentials file of `user`.
    pub fn file_of(&self, user: &str) -> Option<&Path> {
        self.files.get(user).map(PathBuf::as_path)
    }

    /// The router's user/password dictionary.
    pub fn dictionary(&self) -> &Path {
        &self.dictionary
    }

    /// The directory holding them.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for SessionSecrets {
    fn drop(&mut self) {
        if self.remove_on_drop {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_private_distinct_and_gone_when_dropped() {
        let parent = std::env::temp_dir();
        let session = format!("t{}", std::process::id());
        let s =
            SessionSecrets::create(&parent, &session, &["sim".into(), "camera-O1".into()]).unwrap();
        let dir = s.dir().to_path_buf();
        let mode = std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700);
        let sim = Credentials::read(s.file_of("sim").unwrap()).unwrap();
        let cam = Credentials::read(s.file_of("camera-O1").unwrap()).unwrap();
        assert_eq!(sim.user, "sim");
        assert_ne!(sim.password(), cam.password());
        assert_eq!(sim.password().len(), 32);
        let fmode = std::fs::metadata(s.file_of("sim").unwrap())
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(fmode, 0o600);
        let dict = std::fs::read_to_string(s.dictionary()).unwrap();
        assert_eq!(dict.lines().count(), 2);
        assert!(!format!("{sim:?}").contains(sim.password()));
        drop(s);
        assert!(!dir.exists());
        let bad = parent.join(format!("waggle-bad-cred-{}", std::process::id()));
        std::fs::write(&bad, "no colon").unwrap();
        assert!(
            matches!(Credentials::read(&bad), Err(BusError::Credentials(m)) if m.contains("user:password"))
        );
        std::fs::remove_file(&bad).unwrap();
    }

    #[test]
    fn kept_secrets_stay_reopen_and_must_be_private() {
        let dir = std::env::temp_dir().join(format!("waggle-kept-{}", std::process::id()));
        let users = ["sim".to_string(), "launcher-b".to_string()];
        let made = SessionSecrets::create_kept(&dir, &users).unwrap();
        drop(made);
        assert!(dir.join("dictionary").exists());
        let opened = SessionSecrets::open(&dir, &users[1..]).unwrap();
        opened.check_dictionary().unwrap();
        assert!(opened.file_of("launcher-b").is_some());
        assert!(opened.file_of("sim").is_none());
        let missing = SessionSecrets::open(&dir, &["camera-O9".to_string()]);
        assert!(matches!(missing, Err(BusError::Credentials(m)) if m.contains("camera-O9")));
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        let open_dir = SessionSecrets::open(&dir, &users);
        assert!(matches!(open_dir, Err(BusError::Credentials(m)) if m.contains("chmod")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_export_holds_only_the_chosen_credentials_privately() {
        let base = std::env::temp_dir().join(format!("waggle-export-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let all = ["sim".to_string(), "camera-O1".into(), "launcher-b".into()];
        SessionSecrets::create_kept(&base.join("all"), &all).unwrap();
        let b = SessionSecrets::open(&base.join("all"), &all[1..]).unwrap();
        let out = base.join("b");
        let exported = b.export(&out, DictionaryShare::None).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        // Each user's password and certificate, the session CA; nobody else's.
        assert_eq!(
            names,
            [
                "ca.pem",
                "camera-O1.cert.pem",
                "camera-O1.credentials",
                "camera-O1.key.pem",
                "launcher-b.cert.pem",
                "launcher-b.credentials",
                "launcher-b.key.pem"
            ]
        );
        assert_eq!(
            std::fs::metadata(&out).unwrap().permissions().mode() & 0o777,
            0o700
        );
        let file = exported.file_of("camera-O1").unwrap();
        assert_eq!(
            std::fs::metadata(file).unwrap().permissions().mode() & 0o777,
            0o600
        );
        let (copied, original) = (
            Credentials::read(file).unwrap(),
            Credentials::read(b.file_of("camera-O1").unwrap()).unwrap(),
        );
        assert_eq!(
            (&copied.user, copied.password()),
            (&original.user, original.password())
        );
        // Its certificate files are the copies beside it.
        assert_eq!(copied.tls.unwrap().key, out.join("camera-O1.key.pem"));
        // The host can open what it holds, and nothing else.
        SessionSecrets::open(&out, &all[1..]).unwrap();
        assert!(SessionSecrets::open(&out, &all[..1]).is_err());
        assert!(exported.check_dictionary().is_err());
        // The router's host also gets the dictionary; an existing directory is never overwritten.
        let with = b
            .export(&base.join("router"), DictionaryShare::Whole)
            .unwrap();
        with.check_dictionary().unwrap();
        assert!(tls::cert_files(&base.join("router"), tls::ROUTER_CERT_NAME).exist());
        assert!(!tls::cert_files(&out, tls::ROUTER_CERT_NAME).exist());
        assert!(
            matches!(b.export(&out, DictionaryShare::None), Err(BusError::Credentials(m)) if m.contains("exists"))
        );
        // A site router's host: only the entries of the users it serves, no router certificate.
        let served = ["camera-O1".to_string()];
        let site = b
            .export(&base.join("site"), DictionaryShare::Of(&served))
            .unwrap();
        site.check_dictionary().unwrap();
        let dict = std::fs::read_to_string(site.dictionary()).unwrap();
        assert_eq!(dict.lines().count(), 1, "{dict}");
        assert!(dict.starts_with("camera-O1:"));
        assert!(!tls::cert_files(&base.join("site"), tls::ROUTER_CERT_NAME).exist());
        std::fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn secrets_of_a_killed_launcher_are_removed_by_the_next() {
        let parent = std::env::temp_dir().join(format!("waggle-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&parent);
        std::fs::create_dir_all(&parent).unwrap();
        let live = SessionSecrets::create(&parent, "live", &["sim".into()]).unwrap();
        // A launcher that died without dropping its secrets: a process that has exited.
        let mut gone = std::process::Command::new("true").spawn().unwrap();
        let gone_pid = gone.id();
        gone.wait().unwrap();
        let dead = SessionSecrets::create(&parent, "dead", &["sim".into()]).unwrap();
        std::fs::write(dead.dir().join(OWNER_FILE), format!("{gone_pid}\n")).unwrap();
        let dead_dir = dead.dir().to_path_buf();
        std::mem::forget(dead);
        // Kept secrets (beside a compose file) have no owner: never touched.
        let kept =
            SessionSecrets::create_kept(&parent.join("waggle-secrets-kept"), &["sim".into()])
                .unwrap();
        assert_eq!(SessionSecrets::remove_stale(&parent), 1);
        assert!(!dead_dir.exists());
        assert!(live.dir().exists() && kept.dir().exists());
        drop(live);
        std::fs::remove_dir_all(&parent).unwrap();
    }
}
