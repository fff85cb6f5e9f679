//! `massid diagnose --out DIR`: a folder or a list of recordings, diagnosed in parallel over
//! recordings (rayon), one massid-diagnosis/1 JSON per recording plus a summary row each.
//!
//! The per-recording job is `cmd::diagnose`'s ([`diagnose_file`], [`to_json`], [`Row`]): the
//! functions `massid diagnose FILE [--summary-row]` runs too, so that the batch, the single
//! run and an external engine mapping that command over files (`scripts/batch_ray.py`) give
//! the same JSONs and rows. This module uses `cmd::diagnose`, never the other way round; the
//! command dispatch (`cmd::run_diagnose`) chooses between one recording and the batch.
//!
//! Resumable: each JSON is written to a temporary file and renamed into place, so a JSON in
//! DIR is always whole; a rerun skips the recordings whose JSON is there (unless --force)
//! and rebuilds `summary.jsonl` / `summary.csv` from the JSONs present, sorted by file,
//! whatever order the jobs finished in. A recording's JSON is `DIR/KEY.json`, KEY its path
//! below the folder holding every recording of the run ([`json_keys`]), so recordings named
//! alike in different folders neither share a JSON nor a resume decision. The seconds each
//! diagnosis took are kept beside its JSON (`KEY.seconds`), so the JSON stays the exact
//! bytes `--json` writes.
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use rayon::prelude::*;

use super::diagnose::{diagnose_file, to_json, Options, Row, CSV_HEADER};

/// The summary files in the output directory.
pub const SUMMARY_JSONL: &str = "summary.jsonl";
pub const SUMMARY_CSV: &str = "summary.csv";

/// What `--out` asks for.
pub struct Batch {
    pub recordings: Vec<PathBuf>,
    pub list: Option<PathBuf>,
    pub out: PathBuf,
    pub jobs: Option<usize>,
    pub force: bool,
    pub options: Options,
}

/// Whether a path names a recording when it is found in a folder.
fn is_csv(p: &Path) -> bool {
    p.is_file()
        && p.extension()
            .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("csv"))
}

/// A folder's recordings: its `*.csv` files, sorted (not its subfolders).
fn folder(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot read the folder: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_csv(p))
        // a batch's own summary in the folder is not a recording (--out may be the folder)
        .filter(|p| p.file_name().is_none_or(|n| n != SUMMARY_CSV))
        .collect();
    found.sort();
    if found.is_empty() {
        bail!("{}: a folder with no *.csv recording", dir.display());
    }
    Ok(found)
}

/// Every recording the batch names, in the order given: positional paths (a folder: its
/// `*.csv` files), then the list's lines. Missing paths are refused before any work.
pub fn recordings(given: &[PathBuf], list: Option<&Path>) -> anyhow::Result<Vec<PathBuf>> {
    let mut all = Vec::new();
    for p in given {
        if p.is_dir() {
            all.extend(folder(p)?);
        } else if p.exists() {
            all.push(p.clone());
        } else {
            bail!("{}: no such file or folder", p.display());
        }
    }
    if let Some(list) = list {
        let text = std::fs::read_to_string(list)
            .map_err(|e| anyhow::anyhow!("{}: cannot read the list: {e}", list.display()))?;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let p = PathBuf::from(line);
            if p.is_dir() {
                all.extend(folder(&p)?);
            } else if p.exists() {
                all.push(p);
            } else {
                bail!(
                    "{}:{}: {line}: no such file or folder",
                    list.display(),
                    i + 1
                );
            }
        }
    }
    // The same recording twice (the same path, or another spelling of it) is one recording.
    let mut seen = std::collections::HashSet::new();
    all.retain(|p| seen.insert(p.canonicalize().unwrap_or_else(|_| p.clone())));
    if all.is_empty() {
        bail!("no recordings given (name files or folders, or --list FILE)");
    }
    Ok(all)
}

/// The deepest folder holding every recording (paths canonical, so symlinks resolved).
fn common_root(canonical: &[PathBuf]) -> PathBuf {
    let mut root = canonical
        .first()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    for p in canonical {
        while !p.starts_with(&root) {
            match root.parent() {
                Some(up) => root = up.to_path_buf(),
                None => break,
            }
        }
    }
    root
}

/// Each recording's key: where its JSON goes in the output folder, relative to it, which is
/// also what a rerun looks for to skip it (resume). The key is the recording's path relative
/// to the deepest folder holding every recording of the run (symlinks resolved), with
/// `.json` for its extension: `a/flight.csv` and `b/flight.csv` give `a/flight.json` and
/// `b/flight.json`; the recordings of one folder `NAME.json`. It depends on the recordings
/// named, not on the current directory nor on their order, so the same command resumes from
/// anywhere. `scripts/batch_ray.py` computes the same keys.
pub fn json_keys(files: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let canonical = files
        .iter()
        .map(|f| {
            f.canonicalize()
                .map_err(|e| anyhow::anyhow!("{}: {e}", f.display()))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let root = common_root(&canonical);
    Ok(canonical
        .iter()
        .map(|c| {
            let rel = c.strip_prefix(&root).unwrap_or(c);
            let mut key = rel.to_path_buf();
            if key.file_name().is_none() {
                key = PathBuf::from("recording");
            }
            key.set_extension("json");
            key
        })
        .collect())
}

fn seconds_path(json: &Path) -> PathBuf {
    json.with_extension("seconds")
}

/// Writes `text` to `path` through a temporary file in the same folder and a rename: an
/// interrupted run leaves the old file or the new one, never a half-written one.
pub fn write_atomic(path: &Path, text: &str) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, text)
        .and_then(|_| std::fs::rename(&tmp, path))
        .map_err(|e| {
            std::fs::remove_file(&tmp).ok();
            anyhow::anyhow!("{}: cannot write: {e}", path.display())
        })
}

fn duration(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{} h {:02} min", s / 3600, (s % 3600) / 60)
    } else if s >= 60 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}

/// Progress on stderr: a bar with the time left on a terminal, else a plain line now and
/// then (at most one every 10 s, and the last) so that a log shows how far a long batch is.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    start: Instant,
    total: usize,
    /// Recordings done, and when a plain line was last printed.
    state: Mutex<(usize, Instant)>,
}

impl Progress {
    fn new(total: usize) -> Progress {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(total as u64);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} recordings, about {eta} left {msg}",
                )
                .expect("a valid template"),
            );
            bar.enable_steady_tick(Duration::from_millis(200));
            bar
        });
        Progress {
            bar,
            start: Instant::now(),
            total,
            state: Mutex::new((0, Instant::now())),
        }
    }

    fn finished(&self, file: &Path, failed: Option<&str>) {
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        state.0 += 1;
        let done = state.0;
        if let Some(e) = failed {
            let line = format!("massid: {}: failed: {e}", file.display());
            match &self.bar {
                Some(b) => b.println(line),
                None => eprintln!("{line}"),
            }
        }
        if let Some(b) = &self.bar {
            b.inc(1);
            b.set_message(format!("(last: {})", file.display()));
            return;
        }
        if done == self.total || state.1.elapsed() >= Duration::from_secs(10) {
            state.1 = Instant::now();
            let elapsed = self.start.elapsed();
            let left = elapsed.mul_f64((self.total - done) as f64 / done as f64);
            eprintln!(
                "diagnose: {done}/{} recordings done, {} elapsed, about {} left",
                self.total,
                duration(elapsed),
                duration(left)
            );
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Diagnoses one recording of the batch into `json`: the JSON and its seconds written
/// atomically; on failure (bad recording, write error, a panic) the error row (boxed: a row
/// is large and the success path carries nothing).
fn job(recording: &Path, json: &Path, options: &Options) -> Result<(), Box<Row>> {
    let started = Instant::now();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        diagnose_file(recording, options, false).and_then(|d| to_json(&d.analysis))
    }));
    let seconds = started.elapsed().as_secs_f64();
    // a failed job leaves no JSON behind (a --force rerun's old one included), so a later
    // run does not skip the recording as diagnosed
    let fail = |e: String| {
        let _ = std::fs::remove_file(json);
        let _ = std::fs::remove_file(seconds_path(json));
        Box::new(Row::error(recording, &e, Some(seconds)))
    };
    match result {
        Ok(Ok(text)) => {
            // the seconds first: a JSON present is a finished job with its seconds
            write_atomic(&seconds_path(json), &format!("{seconds:.3}\n"))
                .map_err(|e| fail(format!("{e:#}")))?;
            write_atomic(json, &text).map_err(|e| fail(format!("{e:#}")))
        }
        Ok(Err(e)) => Err(fail(format!("{e:#}"))),
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(fail(format!(
                "{}: internal error (panic: {what})",
                recording.display()
            )))
        }
    }
}

/// The summary rows of `files` (their JSONs in `out` at `keys`, [`json_keys`]), sorted by
/// file: a failure of this run gives its error row (`failed`, by key), a JSON present in
/// `out` its row (seconds from its `.seconds` file, if any).
pub fn summary_rows(
    files: &[PathBuf],
    keys: &[PathBuf],
    out: &Path,
    failed: &BTreeMap<PathBuf, Row>,
) -> Vec<Row> {
    let mut rows: Vec<Row> = files
        .iter()
        .zip(keys)
        .map(|(f, key)| {
            if let Some(row) = failed.get(key) {
                return row.clone();
            }
            let json = out.join(key);
            let seconds = std::fs::read_to_string(seconds_path(&json))
                .ok()
                .and_then(|s| s.trim().parse::<f64>().ok());
            match std::fs::read_to_string(&json) {
                Ok(text) => Row::from_json(f, &text, seconds).unwrap_or_else(|e| {
                    Row::error(
                        f,
                        &format!(
                            "{}: {e:#} (delete it, or rerun with --force)",
                            json.display()
                        ),
                        None,
                    )
                }),
                Err(e) => Row::error(f, &format!("{}: {e}", json.display()), None),
            }
        })
        .collect();
    rows.sort_by(|a, b| a.file.cmp(&b.file));
    rows
}

/// `massid diagnose --out DIR ...`.
pub fn run(b: Batch) -> anyhow::Result<()> {
    let out = &b.out;
    if super::is_stdout(out) {
        bail!("--out -: the batch writes a folder (one JSON per recording and a summary), not a stream; for one recording use --json -");
    }
    if out.exists() && !out.is_dir() {
        bail!(
            "{}: exists and is not a directory (--out names a directory)",
            out.display()
        );
    }
    let threads = match b.jobs {
        Some(0) => bail!("--jobs 0: at least one recording at a time"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let files = recordings(&b.recordings, b.list.as_deref())?;
    // A bad model file fails every recording: say so once, before any work.
    if let Some(m) = &b.options.model {
        massid_sim::model_file::ModelFile::read(m)?;
    }
    // Every output is checked before any work: distinct names, never an input.
    let mut inputs: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    if let Some(m) = &b.options.model {
        inputs.push(m);
    }
    if let Some(l) = &b.list {
        inputs.push(l);
    }
    let keys = json_keys(&files)?;
    let mut outputs: BTreeMap<&PathBuf, &PathBuf> = BTreeMap::new();
    for (f, key) in files.iter().zip(&keys) {
        if let Some(other) = outputs.insert(key, f) {
            bail!(
                "{} and {}: both would be diagnosed into {} (diagnose them into different --out folders)",
                other.display(),
                f.display(),
                out.join(key).display()
            );
        }
    }
    if !out.exists() {
        std::fs::create_dir_all(out)
            .map_err(|e| anyhow::anyhow!("{}: cannot create directory: {e}", out.display()))?;
        eprintln!("note: created directory {}", out.display());
    }
    for key in outputs.keys() {
        super::check_output(&out.join(key), &inputs, true)?;
    }
    for name in [SUMMARY_JSONL, SUMMARY_CSV] {
        super::check_output(&out.join(name), &inputs, true)?;
    }
    let todo: Vec<(&PathBuf, &PathBuf)> = files
        .iter()
        .zip(&keys)
        .filter(|(_, key)| b.force || !out.join(key).exists())
        .collect();
    let skipped = files.len() - todo.len();
    eprintln!(
        "diagnose: {} recordings into {}: {} to do on {threads} thread{}{}",
        files.len(),
        out.display(),
        todo.len(),
        if threads == 1 { "" } else { "s" },
        if skipped > 0 {
            format!(", {skipped} already diagnosed there (skipped; --force redoes them)")
        } else {
            String::new()
        }
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        // the main thread's stack, not rayon's 2 MiB default
        .stack_size(8 << 20)
        .build()
        .context("cannot start the worker threads")?;
    let progress = Progress::new(todo.len());
    let started = Instant::now();
    let failed: BTreeMap<PathBuf, Row> = pool.install(|| {
        todo.par_iter()
            .with_max_len(1)
            .filter_map(|&(f, key)| {
                let result = job(f, &out.join(key), &b.options);
                progress.finished(f, result.as_ref().err().and_then(|r| r.error.as_deref()));
                result.err().map(|row| (key.clone(), *row))
            })
            .collect()
    });
    progress.finish();
    let rows = summary_rows(&files, &keys, out, &failed);
    write_atomic(
        &out.join(SUMMARY_JSONL),
        &rows.iter().map(Row::line).collect::<String>(),
    )?;
    write_atomic(
        &out.join(SUMMARY_CSV),
        &(CSV_HEADER.to_string() + &rows.iter().map(Row::csv).collect::<String>()),
    )?;
    let errors = rows.iter().filter(|r| r.status != "ok").count();
    super::mix::emit(&format!(
        "diagnosed {} of {} recordings in {:.1} s ({skipped} skipped, {errors} failed); summary: {}\n",
        todo.len() - failed.len(),
        files.len(),
        started.elapsed().as_secs_f64(),
        out.join(SUMMARY_JSONL).display()
    ))?;
    if errors > 0 {
        bail!(
            "{errors} of {} recordings could not be diagnosed (their error rows are in {})",
            files.len(),
            out.join(SUMMARY_JSONL).display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_paths_below_the_common_folder() {
        let root = |v: &[&str]| {
            common_root(&v.iter().map(PathBuf::from).collect::<Vec<_>>())
                .display()
                .to_string()
        };
        assert_eq!(root(&["/d/o/x.csv", "/d/o/y.csv"]), "/d/o");
        assert_eq!(root(&["/d/a/f.csv", "/d/b/f.csv", "/d/a/c/g.csv"]), "/d");
        // components, not characters: /d/ab is not below /d/a
        assert_eq!(root(&["/d/a/f.csv", "/d/ab/f.csv"]), "/d");
        assert_eq!(root(&["/d/o/x.csv"]), "/d/o");
        assert_eq!(root(&["/a/x.csv", "/b/x.csv"]), "/");
        let dir = std::env::temp_dir().join(format!("massid-keys-{}", std::process::id()));
        for sub in ["a", "b"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
            std::fs::write(dir.join(sub).join("x.y.csv"), "").unwrap();
        }
        let files = [dir.join("a/x.y.csv"), dir.join("b/./x.y.csv")];
        let keys = json_keys(&files).unwrap();
        assert_eq!(keys, [PathBuf::from("a/x.y.json"), "b/x.y.json".into()]);
        assert_eq!(json_keys(&files[..1]).unwrap(), [PathBuf::from("x.y.json")]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
