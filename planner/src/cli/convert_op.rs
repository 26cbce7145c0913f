//! `planner convert-op`: convert orienteering benchmark files into
//! `auv-route-instance/1` JSON: the classic sets (`shared/benchmarks/op/`,
//! `.txt`) and OPLib's TSPLIB-based files (`shared/benchmarks/oplib/`,
//! `.oplib`), each in its documented encoding.
//!
//! Contract: a single file is written to `--out` (or into `--out` when that
//! is an existing folder); a folder is searched recursively for `.txt` and
//! `.oplib` files, each written as `<name>.json` at the same relative place
//! under `--out`. The instance is named after the file (without its
//! extension). Files are
//! processed in sorted order and the first malformed one stops the run with
//! its path, line and column.

use std::path::{Path, PathBuf};

use super::{CliError, print, write_text};

/// Arguments of `planner convert-op`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A benchmark file (`.txt` or `.oplib`), or a folder searched
    /// recursively for them.
    #[arg(value_name = "FILE|DIR")]
    pub input: PathBuf,
    /// Output JSON file (or an existing folder) for one input file; output
    /// folder (created if missing) for an input folder.
    #[arg(long, value_name = "FILE|DIR")]
    pub out: PathBuf,
}

/// Runs `planner convert-op`.
pub fn run(args: Args) -> Result<(), CliError> {
    let meta = std::fs::metadata(&args.input).map_err(|source| CliError::Read {
        path: args.input.clone(),
        source,
    })?;
    if meta.is_dir() {
        convert_tree(&args.input, &args.out)
    } else {
        let out = if args.out.is_dir() {
            args.out.join(json_name(&args.input))
        } else {
            args.out.clone()
        };
        let summary = convert_file(&args.input, &out)?;
        print(&format!("wrote {} ({summary})\n", out.display()))
    }
}

/// `<stem>.json` for a benchmark file.
fn json_name(file: &Path) -> PathBuf {
    PathBuf::from(stem(file)).with_extension("json")
}

fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Converts one file; returns a short description of what was written.
fn convert_file(input: &Path, out: &Path) -> Result<String, CliError> {
    let inst = super::load_benchmark(input).unwrap_or_else(|| {
        Err(CliError::Usage(format!(
            "{}: not a benchmark file (expected .txt or .oplib)",
            input.display()
        )))
    })?;
    write_text(out, &(inst.to_json() + "\n"))?;
    let oplib = input.extension().is_some_and(|e| e == "oplib");
    Ok(if oplib {
        format!(
            "{} nodes, budget {} (COST_LIMIT + 0.5)",
            inst.nodes.len(),
            inst.time_available_s
        )
    } else {
        format!("{} nodes, Tmax {}", inst.nodes.len(), inst.time_available_s)
    })
}

fn convert_tree(root: &Path, out_root: &Path) -> Result<(), CliError> {
    if out_root.exists() && !out_root.is_dir() {
        return Err(CliError::Usage(format!(
            "--out {} is a file, but the input {} is a folder: give a folder",
            out_root.display(),
            root.display()
        )));
    }
    let mut files = Vec::new();
    super::collect_files(root, &["txt", "oplib"], &mut files)?;
    if files.is_empty() {
        return Err(CliError::Usage(format!(
            "no .txt or .oplib benchmark files under {}",
            root.display()
        )));
    }
    for file in &files {
        // `file` was found under `root`, so the prefix is there.
        let rel = file.strip_prefix(root).unwrap_or(file);
        let out = out_root.join(rel).with_extension("json");
        if let Some(dir) = out.parent() {
            std::fs::create_dir_all(dir).map_err(|source| CliError::Write {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        convert_file(file, &out)?;
    }
    print(&format!(
        "converted {} files from {} into {}\n",
        files.len(),
        root.display(),
        out_root.display()
    ))
}
