//! One module per subcommand.
pub mod characterize;
pub mod demo;
pub mod diagnose;
pub mod estimate;
pub mod import;
pub mod mix;
pub mod model;
pub mod simulate;

/// Refuses to write `out` when it is the same file as any input (a tool never overwrites
/// its input), and creates its parent directory, saying so on stderr (a mistyped path must
/// not quietly become a new directory).
pub fn check_output(out: &std::path::Path, inputs: &[&std::path::Path]) -> anyhow::Result<()> {
    if let Ok(o) = out.canonicalize() {
        for i in inputs {
            if i.canonicalize().map(|c| c == o).unwrap_or(false) {
                anyhow::bail!("{}: refusing to overwrite an input file", out.display());
            }
        }
    }
    if let Some(parent) = out.parent() {
        if !parent.as_os_str().is_empty() && !parent.exists() {
            std::fs::create_dir_all(parent).map_err(|e| {
                anyhow::anyhow!("{}: cannot create directory: {e}", parent.display())
            })?;
            eprintln!("note: created directory {}", parent.display());
        }
    }
    Ok(())
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
        assert!(check_output(&input, &[&input]).is_err());
        // through another spelling of the same path too
        let other = dir.join(".").join("in.csv");
        assert!(check_output(&other, &[&input]).is_err());
        let nested = dir.join("new").join("out.json");
        check_output(&nested, &[&input]).unwrap();
        assert!(dir.join("new").is_dir());
        std::fs::remove_dir_all(&dir).ok();
    }
}
