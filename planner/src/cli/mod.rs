//! The command-line layer: one module per subcommand, each with an `Args`
//! struct (clap derive) and a `run(args) -> Result<(), CliError>`, plus the
//! file and terminal helpers they share.
//!
//! Contract: nothing here panics on user input. Every failure is a
//! [`CliError`] whose message is one line naming the file or argument and
//! what is wrong with it; [`CliError::exit_code`] is 2 for bad input
//! (files, arguments) and 1 for failures that are not the user's input
//! (an unwritable output, a planner defect).

pub mod convert_op;
pub mod export;
pub mod montecarlo;
pub mod quality;
pub mod replay;
pub mod scaling;
pub mod solve;
pub mod wire_layout;

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use auv_core::capacity::{Class, LARGEST_NODES};
use auv_core::instance::{Instance, InstanceError};
use auv_core::oplib::OpError;
use auv_core::problem::ProblemError;
use auv_core::tsplib::TsplibError;
use auv_world::scenario::{ConfigError, LoadError};

/// Seed used when `--seed` is not given (our choice; any fixed value would
/// do). The output always reports the seed it used.
pub const DEFAULT_SEED: u64 = 1;

/// Exit code for bad input files or arguments (clap uses 2 as well).
pub const EXIT_INPUT: u8 = 2;
/// Exit code for failures that are not the input's fault.
pub const EXIT_FAILURE: u8 = 1;

/// Why a subcommand failed.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// An input file or folder could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The path.
        path: PathBuf,
        /// The OS error.
        source: io::Error,
    },
    /// An output could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The path (or `standard output`).
        path: PathBuf,
        /// The OS error.
        source: io::Error,
    },
    /// A file that must be JSON is not.
    #[error("{}: not valid JSON: {detail}", path.display())]
    NotJson {
        /// The file.
        path: PathBuf,
        /// Where and what, from the JSON parser.
        detail: String,
    },
    /// An instance file breaks the interchange format.
    #[error("{}: {source}", path.display())]
    Instance {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: InstanceError,
    },
    /// A valid instance the planner cannot plan on (too large, goal unreachable).
    #[error("{}: {source}", path.display())]
    Problem {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: ProblemError,
    },
    /// A malformed orienteering benchmark file.
    #[error("{}: {source}", path.display())]
    Op {
        /// The file.
        path: PathBuf,
        /// What is wrong, with line and column.
        source: OpError,
    },
    /// A malformed OPLib (TSPLIB-based orienteering) file.
    #[error("{}: {source}", path.display())]
    Oplib {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the line.
        source: TsplibError,
    },
    /// A scenario file breaks the `auv-scenario/1` format.
    #[error("{}: {source}", path.display())]
    ScenarioConfig {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: ConfigError,
    },
    /// A scenario whose chart or network cannot be built (no water, …).
    #[error("{origin}: {source}")]
    World {
        /// The scenario file, or `default scenario`.
        origin: String,
        /// What is wrong.
        source: LoadError,
    },
    /// A mission file that cannot be run.
    #[error(transparent)]
    Mission(#[from] auv_world::mission_file::MissionError),
    /// Arguments that parse but do not fit together.
    #[error("{0}")]
    Usage(String),
    /// A file that is not a readable mission MCAP log.
    #[error("{}: {source}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: planner::mission::mcap_log::McapLogError,
    },
    /// The planner broke its own contract (a defect, not bad input).
    #[error("internal error (please report): {0}")]
    Internal(String),
}

impl CliError {
    /// The process exit code for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Write { .. } | Self::Internal(_) => EXIT_FAILURE,
            _ => EXIT_INPUT,
        }
    }
}

/// Prints `planner: error: <message>` on one line to stderr.
pub fn report(e: &CliError) {
    // Messages are one line by construction; folding guards against a
    // dependency's multi-line error text.
    eprintln!("planner: error: {}", one_line(&e.to_string()));
}

/// `text` with line breaks turned into spaces.
fn one_line(text: &str) -> String {
    text.trim_end().replace(['\r', '\n'], " ")
}

/// Reads a whole text file.
pub fn read_text(path: &Path) -> Result<String, CliError> {
    std::fs::read_to_string(path).map_err(|source| CliError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes a whole file.
pub fn write_text(path: &Path, text: &str) -> Result<(), CliError> {
    std::fs::write(path, text).map_err(|source| CliError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `text` to stdout. A closed pipe (`planner … | head`) is not an
/// error: the reader has what it wanted.
pub fn print(text: &str) -> Result<(), CliError> {
    let mut out = io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(CliError::Write {
            path: PathBuf::from("standard output"),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Every file under `dir` (recursively) whose extension is one of
/// `extensions`, in sorted order so runs are reproducible. Symlinked folders
/// are not followed (no cycles); symlinked files are read.
pub fn collect_files(dir: &Path, extensions: &[&str], files: &mut Vec<PathBuf>) -> Result<(), CliError> {
    let read_err = |source| CliError::Read {
        path: dir.to_path_buf(),
        source,
    };
    let mut entries = std::fs::read_dir(dir)
        .map_err(read_err)?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(read_err)?;
    entries.sort();
    for path in entries {
        let is_dir = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir());
        if is_dir {
            collect_files(&path, extensions, files)?;
        } else if path.extension().is_some_and(|e| extensions.iter().any(|x| e == *x)) && path.is_file() {
            files.push(path);
        }
    }
    Ok(())
}

/// Reads a benchmark file as an instance: a classic orienteering `.txt`
/// (Tsiligirides, Chao) or an OPLib `.oplib`, each in its documented
/// encoding; the instance is named after the file. `None` for any other
/// extension.
pub fn load_benchmark(path: &Path) -> Option<Result<Instance, CliError>> {
    let file = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let name = auv_core::oplib::instance_name(file);
    let ext = path.extension().and_then(|e| e.to_str())?;
    let read = || read_text(path);
    Some(match ext {
        "txt" => read().and_then(|text| {
            auv_core::oplib::parse_op(&text)
                .map(|op| op.to_instance(name))
                .map_err(|source| CliError::Op {
                    path: path.to_path_buf(),
                    source,
                })
        }),
        "oplib" => read().and_then(|text| {
            auv_core::tsplib::parse_oplib(&text)
                .map(|op| op.to_instance(name))
                .map_err(|source| CliError::Oplib {
                    path: path.to_path_buf(),
                    source,
                })
        }),
        _ => return None,
    })
}

/// The smallest capacity class that holds `inst` (read from `path`), or a
/// one-line error (exit 2) when it has more nodes than the largest.
pub fn capacity_class(inst: &Instance, path: &Path) -> Result<Class, CliError> {
    Class::for_nodes(inst.nodes.len()).map_err(|e| CliError::Problem {
        path: path.to_path_buf(),
        source: ProblemError::TooManyNodes {
            n: e.0,
            capacity: LARGEST_NODES,
        },
    })
}

/// Reads and validates an `auv-route-instance/1` file.
pub fn load_instance(path: &Path) -> Result<Instance, CliError> {
    let text = read_text(path)?;
    check_json(path, &text)?;
    Instance::from_json(&text).map_err(|source| CliError::Instance {
        path: path.to_path_buf(),
        source,
    })
}

/// Checks that `text` is JSON at all, so "not JSON" is told apart from
/// "JSON but not an instance", and names a non-finite number (which JSON
/// cannot hold but people write) instead of a bare syntax error.
pub fn check_json(path: &Path, text: &str) -> Result<(), CliError> {
    let Err(e) = serde_json::from_str::<serde::de::IgnoredAny>(text) else {
        return Ok(());
    };
    let detail = match non_finite_at(text, e.line(), e.column()) {
        Some(word) => format!(
            "line {}, column {}: {word} is not a JSON number (every number must be finite)",
            e.line(),
            e.column()
        ),
        None => e.to_string(),
    };
    Err(CliError::NotJson {
        path: path.to_path_buf(),
        detail,
    })
}

/// The non-finite literal (`NaN`, `Infinity`, …) at a parser error position, if any.
fn non_finite_at(text: &str, line: usize, column: usize) -> Option<&'static str> {
    let l = text.lines().nth(line.checked_sub(1)?)?;
    // serde_json points at or just past the first bad character; look at
    // the word around that column.
    let chars: Vec<char> = l.chars().collect();
    let mut i = column.saturating_sub(1).min(chars.len());
    while i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '-' || chars[i - 1] == '+') {
        i -= 1;
    }
    let word: String = chars[i..]
        .iter()
        .take_while(|c| c.is_alphanumeric() || **c == '-' || **c == '+')
        .collect();
    let bare = word.trim_start_matches(['-', '+']).to_ascii_lowercase();
    match bare.as_str() {
        "nan" => Some("NaN"),
        "inf" | "infinity" => Some("infinity"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn json_error(text: &str) -> String {
        check_json(Path::new("x.json"), text).unwrap_err().to_string()
    }

    #[test]
    fn non_finite_numbers_are_named() {
        for (text, word) in [
            ("{\"a\": NaN}", "NaN"),
            ("{\"a\": 1,\n \"b\": -Infinity}", "infinity"),
            ("[1, inf]", "infinity"),
            ("{\"speed_mps\":nan,\"x\":1}", "NaN"),
        ] {
            let e = json_error(text);
            assert!(e.contains(&format!("{word} is not a JSON number")), "{text}: {e}");
            assert!(e.starts_with("x.json: not valid JSON: line"), "{e}");
        }
    }

    #[test]
    fn other_syntax_errors_keep_the_parser_text() {
        let e = json_error("{\"a\": 1,");
        assert!(e.contains("not valid JSON") && e.contains("line 1"), "{e}");
        assert!(!e.contains("finite"), "{e}");
        assert!(check_json(Path::new("x"), "{\"a\": [1, 2.5e3]}").is_ok());
    }

    #[test]
    fn reports_fold_to_one_line() {
        let e = CliError::Usage("two\nlines".into());
        assert_eq!(one_line(&e.to_string()), "two lines");
        assert_eq!(e.exit_code(), EXIT_INPUT);
        assert_eq!(CliError::Internal("x".into()).exit_code(), EXIT_FAILURE);
    }
}
