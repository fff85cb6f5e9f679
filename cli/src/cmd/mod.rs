//! One module per subcommand.
pub mod characterize;
pub mod demo;
pub mod diagnose;
pub mod estimate;
pub mod mix;
pub mod simulate;

/// Refuses to write `out` when it is the same file as any input (a tool never overwrites
/// its input), and creates its parent directory.
pub fn check_output(out: &std::path::Path, inputs: &[&std::path::Path]) -> anyhow::Result<()> {
    if let Ok(o) = out.canonicalize() {
        for i in inputs {
            if i.canonicalize().map(|c| c == o).unwrap_or(false) {
                anyhow::bail!("{}: refusing to overwrite an input file", out.display());
            }
        }
    }
    if let Some(parent) = out.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent).map_err(|e| {
                anyhow::anyhow!("{}: cannot create directory: {e}", parent.display())
            })?;
        }
    }
    Ok(())
}
