//! `waggle bundle FILE --host NAME --out DIR`: what one host of a session needs, to copy there —
//! the compose file and that host's own credentials (the router's host also gets the router's
//! dictionary), so no host holds another host's passwords.

use anyhow::{Context, Result, bail};

use commands::bundle::BundleArgs;

pub fn run(args: BundleArgs) -> Result<()> {
    let compose = crate::compose::load(&args.file)?;
    let name = args
        .file
        .file_name()
        .with_context(|| format!("{} has no file name", args.file.display()))?;
    if args.out.exists() {
        bail!(
            "--out {}: exists already; name a new directory",
            args.out.display()
        );
    }
    // Opening the host's share first checks the host and every file it needs.
    let secrets = super::up::open_secrets(&compose, &args.file, Some(&args.host))?;
    let target = args.out.join(name);
    let secrets_target = match (&secrets, &compose.secrets) {
        (Some(_), Some(dir)) if dir.is_absolute() => bail!(
            "{} names its secrets by an absolute path ({}): a bundle needs one relative to the file",
            args.file.display(),
            dir.display()
        ),
        (Some(_), Some(_)) => compose.secrets_dir(&target),
        _ => None,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    std::fs::copy(&args.file, &target)
        .with_context(|| format!("copying {} to {}", args.file.display(), target.display()))?;
    let router = args.host == compose.router.host;
    // A site's router checks the passwords of its hosts' processes: their dictionary entries.
    let site_users: Option<Vec<String>> = compose
        .site_on(&args.host)
        .map(|site| site.hosts().flat_map(|h| compose.users_on(h)).collect());
    let share = match (&site_users, router) {
        (_, true) => bus::DictionaryShare::Whole,
        (Some(users), false) => bus::DictionaryShare::Of(users),
        (None, false) => bus::DictionaryShare::None,
    };
    if let (Some(s), Some(dir)) = (&secrets, &secrets_target) {
        s.export(dir, share)
            .with_context(|| format!("writing {}'s credentials", args.host))?;
    }

    let users = compose.users_on(&args.host);
    println!(
        "bundle for host {} of session {} in {}: {}",
        args.host,
        compose.session,
        args.out.display(),
        match &secrets_target {
            Some(dir) => format!(
                "{} and the credentials of {}{} in {}",
                target.display(),
                users.join(", "),
                match share {
                    bus::DictionaryShare::Whole => " with the router's dictionary",
                    bus::DictionaryShare::Of(_) => " with its site's share of the dictionary",
                    bus::DictionaryShare::None => "",
                },
                dir.display()
            ),
            None => format!("{} (no credentials: the session is open)", target.display()),
        }
    );
    println!(
        "copy it there (e.g. scp -rp {}/. {}:run/) and run: waggle up run/{} --host {}",
        args.out.display(),
        args.host,
        name.to_string_lossy(),
        args.host
    );
    Ok(())
}
