//! The lab commands of `waggle` (served by `waggle-lab`): one small adapter per command, each
//! parsing its arguments (clap), calling the library and printing the result. The argument
//! groups they share with the operations are `deploy`'s.

pub mod decode;
pub mod events;
pub mod link;
pub mod mission;
pub mod report;
pub mod shard;
pub mod study;
pub mod sweep;
pub mod trials;
pub mod viewpoints;

pub use deploy::cli::{FlightsArg, PerturbArgs, RenderArg};

/// `--jobs N`: a whole number of at least 1 (0 used to run one job without a word).
pub fn parse_jobs(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1: 0 jobs would run nothing".to_owned()),
        Ok(jobs) => Ok(jobs),
        Err(e) => Err(format!("not a whole number of jobs ({e})")),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_jobs;

    #[test]
    fn jobs_must_be_a_whole_number_of_at_least_one() {
        assert_eq!(parse_jobs("1"), Ok(1));
        assert_eq!(parse_jobs("16"), Ok(16));
        for bad in ["0", "-1", "two", "", "1.5"] {
            assert!(parse_jobs(bad).is_err(), "{bad:?} accepted");
        }
        assert!(parse_jobs("0").unwrap_err().contains("at least 1"));
    }
}
