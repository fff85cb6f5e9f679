//! One module per subcommand.
/// A number as a message quotes it: plain when moderate, else in exponent form (`1e308`,
/// not 309 digits).
pub fn num(x: f64) -> String {
    if x == 0.0 || (1e-4..1e6).contains(&x.abs()) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Where a subcommand's human text goes: stdout, or stderr when stdout carries a JSON
/// document (`--json -`), so that a program reading stdout gets the JSON alone.
#[derive(Clone, Copy, Debug)]
pub struct Text {
    to_stderr: bool,
}

impl Text {
    /// The text's destination given the `--json` output, if any.
    pub fn beside_json(json: Option<&std::path::Path>) -> Text {
        Text {
            to_stderr: json.is_some_and(is_stdout),
        }
    }

    /// Prints one line.
    pub fn line(&self, args: std::fmt::Arguments) {
        if self.to_stderr {
            eprintln!("{args}");
        } else {
            println!("{args}");
        }
    }
}

/// `say!(text, "...", args)`: one line of human text to `text`'s destination ([`Text`]).
macro_rules! say {
    ($text:expr, $($fmt:tt)*) => {
        $text.line(format_args!($($fmt)*))
    };
}

// The subcommands, after the `say!` macro they use (a macro is in scope below its definition).
pub mod batch;
pub mod characterize;
pub mod demo;
pub mod diagnose;
pub mod estimate;
pub mod import;
pub mod inputs;
pub mod mix;
pub mod model;
pub mod simulate;

/// `massid diagnose`: the command dispatch between one recording ([`diagnose::run`]) and many
/// (`--out DIR`, [`batch::run`]). The per-recording job lives in `diagnose`, which the batch
/// uses; `diagnose` does not know the batch, so the dependency runs one way.
pub fn run_diagnose(args: diagnose::Args) -> anyhow::Result<()> {
    match &args.out {
        Some(out) => batch::run(batch::Batch {
            options: args.options()?,
            recordings: args.recordings.clone(),
            list: args.list.clone(),
            out: out.clone(),
            jobs: args.jobs,
            force: args.force,
        }),
        None => diagnose::run(args),
    }
}

/// Whether an output path means standard output (`-`).
pub fn is_stdout(out: &std::path::Path) -> bool {
    out.as_os_str() == "-"
}

/// The one convention for an output path, checked before any work starts: `-` is stdout;
/// never the same file as an input (a tool never overwrites its input); an existing file is
/// replaced only with `--force` (`force`); a directory is no file; a missing parent directory
/// is created, saying so on stderr (a mistyped path must not quietly become a new directory).
pub fn check_output(
    out: &std::path::Path,
    inputs: &[&std::path::Path],
    force: bool,
) -> anyhow::Result<()> {
    if is_stdout(out) {
        return Ok(());
    }
    if let Ok(o) = out.canonicalize() {
        for i in inputs {
            if i.canonicalize().map(|c| c == o).unwrap_or(false) {
                anyhow::bail!("{}: refusing to overwrite an input file", out.display());
            }
        }
    }
    if out.is_dir() {
        anyhow::bail!("{}: is a directory; name a file", out.display());
    }
    if out.exists() && !force {
        anyhow::bail!(
            "{}: exists; refusing to overwrite it (pass --force, or choose another path)",
            out.display()
        );
    }
    if let Some(parent) = out.parent() {
        if !parent.as_os_str().is_empty() {
            if parent.exists() && !parent.is_dir() {
                anyhow::bail!("{}: is a file, not a directory", parent.display());
            }
            if !parent.exists() {
                std::fs::create_dir_all(parent).map_err(|e| {
                    anyhow::anyhow!("{}: cannot create directory: {e}", parent.display())
                })?;
                eprintln!("note: created directory {}", parent.display());
            }
        }
    }
    Ok(())
}

/// Writes `text` to `out` (`-`: stdout; a closed pipe is not an error).
pub fn write_output(out: &std::path::Path, text: &str) -> anyhow::Result<()> {
    if is_stdout(out) {
        return mix::emit(text);
    }
    std::fs::write(out, text).map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", out.display()))
}

#[cfg(test)]
mod tests {
    use super::check_output;

    #[test]
    fn outputs_never_replace_inputs_and_new_directories_are_made() {
        let dir = std::env::temp_dir().join(format!("massid-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = dir.join("in.csv");
        std::fs::write(&input, "x").unwrap();
        assert!(check_output(&input, &[&input], true).is_err());
        // through another spelling of the same path too
        let other = dir.join(".").join("in.csv");
        assert!(check_output(&other, &[&input], true).is_err());
        let nested = dir.join("new").join("out.json");
        check_output(&nested, &[&input], false).unwrap();
        assert!(dir.join("new").is_dir());
        // an existing output only with --force; `-` is stdout
        let existing = dir.join("old.json");
        std::fs::write(&existing, "x").unwrap();
        let e = check_output(&existing, &[&input], false).unwrap_err();
        assert!(e.to_string().contains("--force"), "{e}");
        check_output(&existing, &[&input], true).unwrap();
        check_output(std::path::Path::new("-"), &[&input], false).unwrap();
        // a directory under a file is refused before any work
        assert!(check_output(&existing.join("report.html"), &[&input], true).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
