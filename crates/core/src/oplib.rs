//! Classic orienteering benchmark files (`shared/benchmarks/op/`: the
//! Tsiligirides and Chao sets) and their table of known optima.
//!
//! Contract: [`parse_op`] reads one benchmark file (first line `Tmax P`, then
//! one `x y score` line per node; the first node line is the start, the second
//! the end) and [`OpInstance::to_instance`] maps it onto the interchange
//! format exactly as `instance-format.md` ("Classic orienteering instances")
//! says: scores become node prizes, an edge joins every pair with priority 0,
//! risk 1 and task time 0, speed is 1 and z is 0 (so time equals planar
//! Euclidean distance, unrounded), and the budget is Tmax. Malformed files are
//! rejected with an [`OpError`] naming the line and column.
//! [`BestKnown::parse`] reads `best_known.csv` for quality checks.
//!
//! Units: the benchmark's own (coordinates and Tmax in the same length unit,
//! travelled at speed 1 per second, so seconds and metres coincide).

use std::collections::BTreeMap;

use crate::instance::{Edge, Instance, Node, Objective};

/// Node id of the start in a benchmark file (its first node line).
pub const OP_START: usize = 0;
/// Node id of the end in a benchmark file (its second node line).
pub const OP_END: usize = 1;

/// One benchmark file as read: the budget and the nodes in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct OpInstance {
    /// Length budget Tmax (> 0).
    pub tmax: f64,
    /// Nodes in file order; index 0 is the start, 1 the end.
    pub nodes: Vec<OpNode>,
}

/// One node line of a benchmark file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OpNode {
    /// First coordinate (benchmark length unit).
    pub x: f64,
    /// Second coordinate (benchmark length unit).
    pub y: f64,
    /// Score collected when visited (≥ 0).
    pub score: f64,
}

/// Why a benchmark file was rejected. Line and column are 1-based; the
/// column is the character position where the offending field starts.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OpError {
    /// The file holds no non-blank line.
    #[error("empty file: expected a first line `Tmax P`")]
    Empty,
    /// A line has the wrong number of fields.
    #[error("line {line}: expected {expected} fields ({layout}), found {found}")]
    FieldCount {
        /// Line number.
        line: usize,
        /// Fields expected.
        expected: usize,
        /// Fields found.
        found: usize,
        /// What the fields are, e.g. `x y score`.
        layout: &'static str,
    },
    /// A field is not a number.
    #[error("line {line}, column {column}: {field} {text:?} is not a number")]
    NotANumber {
        /// Line number.
        line: usize,
        /// Column where the field starts.
        column: usize,
        /// Field name.
        field: &'static str,
        /// The text found.
        text: String,
    },
    /// A number breaks its rule (non-finite, negative, …).
    #[error("line {line}, column {column}: {field} = {value} is invalid: must be {rule}")]
    BadValue {
        /// Line number.
        line: usize,
        /// Column where the field starts.
        column: usize,
        /// Field name.
        field: &'static str,
        /// The value found.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// The path count is not 1 (team-orienteering files are not supported).
    #[error("line {line}, column {column}: P = {value}: only single-path files (P = 1) are supported")]
    PathCount {
        /// Line number.
        line: usize,
        /// Column where the field starts.
        column: usize,
        /// The value found.
        value: f64,
    },
    /// Fewer than two node lines (a start and an end are needed).
    #[error("{found} node line(s): a start and an end (at least 2 nodes) are needed")]
    TooFewNodes {
        /// Node lines found.
        found: usize,
    },
}

/// Splits a line into fields with the 1-based column where each starts.
fn fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut rest = line;
    let mut offset = 0;
    core::iter::from_fn(move || {
        let skip = rest.len() - rest.trim_start().len();
        offset += skip;
        rest = &rest[skip..];
        if rest.is_empty() {
            return None;
        }
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let field = &rest[..end];
        // Columns count characters, not bytes, so a stray non-ASCII
        // character does not shift the reported position.
        let column = line[..offset].chars().count() + 1;
        offset += end;
        rest = &rest[end..];
        Some((column, field))
    })
}

struct Field<'a> {
    line: usize,
    column: usize,
    name: &'static str,
    text: &'a str,
}

impl Field<'_> {
    fn number(&self) -> Result<f64, OpError> {
        self.text.parse::<f64>().map_err(|_| OpError::NotANumber {
            line: self.line,
            column: self.column,
            field: self.name,
            text: self.text.to_string(),
        })
    }

    fn checked(&self, ok: impl Fn(f64) -> bool, rule: &'static str) -> Result<f64, OpError> {
        let value = self.number()?;
        // `parse` accepts "inf" and "NaN"; the benchmark never holds them.
        if value.is_finite() && ok(value) {
            Ok(value)
        } else {
            Err(OpError::BadValue {
                line: self.line,
                column: self.column,
                field: self.name,
                value,
                rule,
            })
        }
    }
}

/// Reads the fields of `line` (number `line_no`) named by `names`.
fn split_line<'a>(
    line_no: usize,
    line: &'a str,
    names: &'static [&'static str],
    layout: &'static str,
) -> Result<Vec<Field<'a>>, OpError> {
    let found: Vec<(usize, &str)> = fields(line).collect();
    if found.len() != names.len() {
        return Err(OpError::FieldCount {
            line: line_no,
            expected: names.len(),
            found: found.len(),
            layout,
        });
    }
    Ok(found
        .into_iter()
        .zip(names)
        .map(|((column, text), &name)| Field {
            line: line_no,
            column,
            name,
            text,
        })
        .collect())
}

/// Parses one benchmark file. Blank lines are skipped; LF and CRLF line
/// endings are both accepted (the two public copies differ only in that).
pub fn parse_op(text: &str) -> Result<OpInstance, OpError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    let (line_no, header) = lines.next().ok_or(OpError::Empty)?;
    let head = split_line(line_no, header, &["Tmax", "P"], "Tmax P")?;
    let tmax = head[0].checked(|v| v > 0.0, "finite and > 0")?;
    let paths = head[1].checked(|_| true, "finite")?;
    if paths != 1.0 {
        return Err(OpError::PathCount {
            line: line_no,
            column: head[1].column,
            value: paths,
        });
    }
    let mut nodes = Vec::new();
    for (line_no, line) in lines {
        let f = split_line(line_no, line, &["x", "y", "score"], "x y score")?;
        // Coordinates may be negative (the Chao sets are centred on 0).
        nodes.push(OpNode {
            x: f[0].checked(|_| true, "finite")?,
            y: f[1].checked(|_| true, "finite")?,
            score: f[2].checked(|v| v >= 0.0, "finite and >= 0")?,
        });
    }
    if nodes.len() < 2 {
        return Err(OpError::TooFewNodes { found: nodes.len() });
    }
    Ok(OpInstance { tmax, nodes })
}

impl OpInstance {
    /// Maps the file onto the interchange format (see the module header).
    pub fn to_instance(&self, name: &str) -> Instance {
        let n = self.nodes.len();
        let nodes = self
            .nodes
            .iter()
            .map(|p| Node {
                x: p.x,
                y: p.y,
                z: 0.0,
                prize: p.score,
            })
            .collect();
        let mut edges = Vec::with_capacity(n * (n - 1) / 2);
        for a in 0..n {
            for b in a + 1..n {
                edges.push(Edge {
                    a,
                    b,
                    priority: 0.0,
                    risk: 1.0,
                    task_time_s: 0.0,
                });
            }
        }
        Instance {
            name: name.to_string(),
            speed_mps: 1.0,
            time_available_s: self.tmax,
            start: OP_START,
            goal: OP_END,
            nodes,
            edges,
            objective: Objective::MaxWeight,
        }
    }
}

/// One row of `best_known.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct BestKnownEntry {
    /// Benchmark set (folder name), e.g. `tsiligirides_set1`.
    pub set: String,
    /// Node lines in the file, start and end included.
    pub n_nodes: usize,
    /// Length budget.
    pub tmax: f64,
    /// Best known (here: proven optimal) score.
    pub score: f64,
    /// Whether the optimum was certified by an exact run.
    pub proved_optimal: bool,
}

/// Why `best_known.csv` was rejected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BestKnownError {
    /// The header is not the documented one.
    #[error("line 1: expected header starting {expected:?}")]
    Header {
        /// The expected column names.
        expected: &'static str,
    },
    /// A row is malformed.
    #[error("line {line}: {what}")]
    Row {
        /// Line number.
        line: usize,
        /// What is wrong.
        what: String,
    },
}

/// The known optima, keyed by instance name (file name without `.txt`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BestKnown {
    entries: BTreeMap<String, BestKnownEntry>,
}

const BEST_KNOWN_HEADER: &str = "set,instance,n_nodes,tmax,best_known_score,proved_optimal";

/// The header of OPLib's table (`shared/benchmarks/oplib/best_known.csv`):
/// the same facts, in another order and with a file column.
const OPLIB_BEST_KNOWN_HEADER: &str = "file,instance,generation,dimension,cost_limit,best_known_score,proved_optimal";

/// The instance name of a benchmark file name: the name without `.txt`
/// (classic files) or `.oplib` (OPLib files).
pub fn instance_name(file_name: &str) -> &str {
    file_name
        .strip_suffix(".txt")
        .or_else(|| file_name.strip_suffix(".oplib"))
        .unwrap_or(file_name)
}

impl BestKnown {
    /// Parses `best_known.csv` (columns
    /// `set,instance,n_nodes,tmax,best_known_score,proved_optimal,source`;
    /// the free-text `source` column is ignored).
    pub fn parse(text: &str) -> Result<Self, BestKnownError> {
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
        let oplib = match lines.next() {
            Some((_, h)) if h.starts_with(BEST_KNOWN_HEADER) => false,
            Some((_, h)) if h.starts_with(OPLIB_BEST_KNOWN_HEADER) => true,
            _ => {
                return Err(BestKnownError::Header {
                    expected: BEST_KNOWN_HEADER,
                });
            }
        };
        let mut entries = BTreeMap::new();
        for (line, row) in lines.filter(|(_, l)| !l.trim().is_empty()) {
            let bad = |what: String| BestKnownError::Row { line, what };
            // The last column is free text; splitting at most 7 ways keeps
            // any comma inside it out of the numeric columns.
            let mut cols: Vec<&str> = row.splitn(7, ',').map(str::trim).collect();
            if oplib {
                if cols.len() < 7 {
                    return Err(bad(format!("expected 7 columns, found {}", cols.len())));
                }
                // file,instance,generation,dimension,cost_limit,score,proved
                // → set (the generation),instance,n_nodes,tmax,score,proved.
                cols = vec![cols[2], cols[1], cols[3], cols[4], cols[5], cols[6]];
            }
            if cols.len() < 6 {
                return Err(bad(format!("expected at least 6 columns, found {}", cols.len())));
            }
            let number = |i: usize, name: &str| -> Result<f64, BestKnownError> {
                cols[i]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0)
                    .ok_or_else(|| bad(format!("{name} {:?} is not a finite number >= 0", cols[i])))
            };
            let n_nodes = cols[2]
                .parse::<usize>()
                .map_err(|_| bad(format!("n_nodes {:?} is not a whole number", cols[2])))?;
            let tmax = number(3, "tmax")?;
            let score = number(4, "best_known_score")?;
            let proved_optimal = match cols[5] {
                "yes" => true,
                "no" => false,
                other => return Err(bad(format!("proved_optimal {other:?} is not yes or no"))),
            };
            let name = instance_name(cols[1]).to_string();
            let entry = BestKnownEntry {
                set: cols[0].to_string(),
                n_nodes,
                tmax,
                score,
                proved_optimal,
            };
            if entries.insert(name.clone(), entry).is_some() {
                return Err(bad(format!("instance {name:?} is listed twice")));
            }
        }
        Ok(Self { entries })
    }

    /// The entry of an instance, by name with or without `.txt`.
    pub fn get(&self, instance: &str) -> Option<&BestKnownEntry> {
        self.entries.get(instance_name(instance))
    }

    /// Number of instances listed.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no instance is listed.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// All entries in name order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &BestKnownEntry)> {
        self.entries.iter().map(|(k, v)| (k.as_str(), v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::route::RouteStats;

    // Tsiligirides set 1's first four node lines with its smallest budget.
    const SMALL: &str = "5\t1\n10.5\t14.4\t0\n11.2\t14.1\t0\n18\t15.9\t10\n18.3\t13.3\t10\n";

    #[test]
    fn reads_budget_and_nodes_in_file_order() {
        let op = parse_op(SMALL).unwrap();
        assert_eq!(op.tmax, 5.0);
        assert_eq!(op.nodes.len(), 4);
        assert_eq!(
            op.nodes[2],
            OpNode {
                x: 18.0,
                y: 15.9,
                score: 10.0
            }
        );
    }

    #[test]
    fn crlf_blank_lines_and_negative_coordinates_are_fine() {
        let op = parse_op("15 1\r\n\r\n0.000 -7.000 0\r\n-0.5 0 0\r\n1 1 20\r\n\r\n").unwrap();
        assert_eq!(op.nodes.len(), 3);
        assert_eq!(op.nodes[0].y, -7.0);
        assert_eq!(op.nodes[1].x, -0.5);
    }

    #[test]
    fn maps_onto_the_format_as_documented() {
        let inst = parse_op(SMALL).unwrap().to_instance("tiny");
        assert_eq!(inst.name, "tiny");
        assert_eq!((inst.start, inst.goal), (0, 1));
        assert_eq!(inst.speed_mps, 1.0);
        assert_eq!(inst.time_available_s, 5.0);
        assert_eq!(inst.objective, Objective::MaxWeight);
        assert!(inst.nodes.iter().all(|n| n.z == 0.0));
        assert_eq!(
            inst.nodes.iter().map(|n| n.prize).collect::<Vec<_>>(),
            [0.0, 0.0, 10.0, 10.0]
        );
        // Every pair exactly once.
        assert_eq!(inst.edges.len(), 6);
        for a in 0..4 {
            for b in 0..4 {
                assert_eq!(inst.edge_between(a, b).is_some(), a != b, "{a}-{b}");
            }
        }
        assert!(
            inst.edges
                .iter()
                .all(|e| e.priority == 0.0 && e.risk == 1.0 && e.task_time_s == 0.0)
        );
        // And it survives the format's own validation.
        assert_eq!(Instance::from_json(&inst.to_json()).unwrap(), inst);
    }

    #[test]
    fn route_time_is_unrounded_planar_distance_and_weight_is_the_score() {
        let inst = parse_op(SMALL).unwrap().to_instance("tiny");
        let stats = RouteStats::from_instance(&inst, &[0, 2, 3, 1]).unwrap();
        let d = |a: (f64, f64), b: (f64, f64)| ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        let expected = d((10.5, 14.4), (18.0, 15.9)) + d((18.0, 15.9), (18.3, 13.3)) + d((18.3, 13.3), (11.2, 14.1));
        assert!((stats.time_s - expected).abs() < 1e-12);
        assert_eq!(stats.distance_m, stats.time_s);
        assert_eq!(stats.weight, 20.0);
        assert!(!stats.feasible, "{} > Tmax 5", stats.time_s);
    }

    fn err(text: &str) -> String {
        parse_op(text).expect_err(text).to_string()
    }

    #[test]
    fn malformed_files_name_line_and_column() {
        assert_eq!(err(""), "empty file: expected a first line `Tmax P`");
        assert_eq!(err("  \n\n"), "empty file: expected a first line `Tmax P`");
        assert!(err("5\n0 0 0\n1 1 0\n").contains("line 1: expected 2 fields (Tmax P), found 1"));
        assert!(err("5 1\n0 0 0\n1 1\n").contains("line 3: expected 3 fields (x y score), found 2"));
        assert!(err("5 1\n0 0 0\n1 1 0 4\n").contains("line 3: expected 3 fields"));
        assert_eq!(
            err("5 1\n0 0 0\n1\tabc\t0\n"),
            "line 3, column 3: y \"abc\" is not a number"
        );
        assert_eq!(
            err("5 1\n0 0 0\n\n1  2  -3\n"),
            "line 4, column 7: score = -3 is invalid: must be finite and >= 0"
        );
        assert!(err("5 1\n0 NaN 0\n1 1 0\n").contains("line 2, column 3: y = NaN is invalid: must be finite"));
        assert!(err("5 1\n0 0 inf\n1 1 0\n").contains("score = inf is invalid"));
        assert!(err("-5 1\n0 0 0\n1 1 0\n").contains("line 1, column 1: Tmax = -5 is invalid"));
        assert!(err("0 1\n0 0 0\n1 1 0\n").contains("Tmax = 0 is invalid"));
        assert_eq!(
            err("5 2\n0 0 0\n1 1 0\n"),
            "line 1, column 3: P = 2: only single-path files (P = 1) are supported"
        );
        assert!(err("5 1\n0 0 0\n").contains("1 node line(s)"));
        assert!(err("5 1\n").contains("0 node line(s)"));
    }

    #[test]
    fn columns_count_characters() {
        let cols: Vec<(usize, &str)> = fields("  ab\t\tcé  x").collect();
        assert_eq!(cols, [(3, "ab"), (7, "cé"), (11, "x")]);
    }

    const CSV: &str = "set,instance,n_nodes,tmax,best_known_score,proved_optimal,source\n\
        tsiligirides_set1,tsiligirides_problem_1_budget_05.txt,32,5,10,yes,a, b; c\n\
        chao_set64_diamond,set_64_1_15.txt,64,15,96,no,x\n";

    #[test]
    fn best_known_reads_rows_by_instance_name() {
        let bk = BestKnown::parse(CSV).unwrap();
        assert_eq!(bk.len(), 2);
        let e = bk.get("tsiligirides_problem_1_budget_05").unwrap();
        assert_eq!(e.score, 10.0);
        assert_eq!(e.tmax, 5.0);
        assert_eq!(e.n_nodes, 32);
        assert!(e.proved_optimal);
        assert_eq!(bk.get("set_64_1_15.txt").unwrap().set, "chao_set64_diamond");
        assert!(!bk.get("set_64_1_15").unwrap().proved_optimal);
        assert!(bk.get("set_64_1_20").is_none());
    }

    #[test]
    fn best_known_rejects_bad_rows() {
        assert!(BestKnown::parse("a,b\n").is_err());
        let bad_score = CSV.replace(",10,yes", ",ten,yes");
        assert!(
            BestKnown::parse(&bad_score)
                .unwrap_err()
                .to_string()
                .contains("line 2: best_known_score \"ten\"")
        );
        let dup = format!("{CSV}tsiligirides_set1,tsiligirides_problem_1_budget_05.txt,32,5,10,yes,x\n");
        assert!(BestKnown::parse(&dup).unwrap_err().to_string().contains("listed twice"));
        let flag = CSV.replace(",yes,", ",maybe,");
        assert!(BestKnown::parse(&flag).unwrap_err().to_string().contains("maybe"));
    }

    #[test]
    fn shipped_best_known_table_parses() {
        // An unchanged copy of shared/benchmarks/op/best_known.csv.
        let text = include_str!("../tests/data/op/best_known.csv");
        let bk = BestKnown::parse(text).unwrap();
        assert_eq!(bk.len(), 89);
        assert_eq!(bk.get("tsiligirides_problem_1_budget_10.txt").unwrap().score, 15.0);
        assert_eq!(bk.get("set_66_1_130").unwrap().n_nodes, 66);
        assert!(bk.iter().all(|(_, e)| e.proved_optimal));
    }

    #[test]
    fn shipped_file_reads_and_its_reference_path_checks_out() {
        // reference_paths.csv: budget 5, score 10, length 4.142575, path 0 28 1.
        let text = include_str!("../tests/data/op/tsiligirides_set1/tsiligirides_problem_1_budget_05.txt");
        let inst = parse_op(text).unwrap().to_instance("t1-05");
        assert_eq!(inst.nodes.len(), 32);
        assert_eq!(inst.edges.len(), 32 * 31 / 2);
        let stats = RouteStats::from_instance(&inst, &[0, 28, 1]).unwrap();
        assert_eq!(stats.weight, 10.0);
        assert!((stats.time_s - 4.142575).abs() < 1e-6);
        assert!(stats.feasible);
    }
}
