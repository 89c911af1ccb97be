//! Every count flag parsed within its bounds ([`parcal::dataset::bounds`]):
//! `#[arg(long, value_parser = Bounded(parcal::plan::POOL))]`. A value
//! outside them is a usage error (exit status 2) naming the flag, the
//! bounds and why, before anything is read or allocated.

use std::ffi::OsStr;

use clap::error::{Error, ErrorKind};
use parcal::dataset::bounds::Count;

/// A clap value parser of a count within `Count`'s bounds.
#[derive(Clone, Copy)]
pub struct Bounded(pub Count);

impl clap::builder::TypedValueParser for Bounded {
    type Value = usize;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<usize, Error> {
        let flag = arg
            .and_then(clap::Arg::get_long)
            .map_or_else(|| "the count".to_string(), |long| format!("--{long}"));
        let text = value.to_string_lossy();
        // A number beyond usize (or not a number) is refused as out of
        // bounds too, with the same message.
        text.trim()
            .parse::<usize>()
            .map_err(|_| self.0.refusal(&flag, &format!("{text:?}")))
            .and_then(|n| self.0.check(&flag, n))
            .map_err(|message| Error::raw(ErrorKind::ValueValidation, message + "\n").with_cmd(cmd))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::builder::TypedValueParser;

    #[test]
    fn a_flag_beyond_its_bound_is_named_with_the_bound() {
        let parser = Bounded(Count::new(1, 10, "why"));
        let cmd = clap::Command::new("t");
        let arg = clap::Arg::new("n").long("n");
        let parse = |v: &str| parser.parse_ref(&cmd, Some(&arg), OsStr::new(v));
        assert_eq!(parse("10").unwrap(), 10);
        for bad in ["0", "11", "18446744073709551616", "x"] {
            let message = parse(bad).unwrap_err().to_string();
            assert!(
                message.contains("--n") && message.contains("from 1 to 10 (why)"),
                "{message}"
            );
        }
    }
}
