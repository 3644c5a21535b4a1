//! Errors that reach the user. Each says what is wrong and how to fix it.

use std::path::PathBuf;

/// Any error of multifield.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The case file is not valid RON, or does not match the case schema.
    #[error("{file}:{line}:{column}: {message}")]
    Syntax {
        /// The case file.
        file: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// An input file that cannot be taken as a whole (too large, a directory).
    #[error("{file}: {message}")]
    File {
        /// The file.
        file: PathBuf,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// A value is impossible; the message says which entry and how to fix it.
    #[error("{file}: {path}: {message}")]
    Invalid {
        /// The case file (or `<case>` when built in code).
        file: PathBuf,
        /// Dotted path of the entry, e.g. `fields.water.density`.
        path: String,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// A `--set path=value` override could not be applied.
    #[error("--set {assignment}: {message}")]
    Override {
        /// The override as given.
        assignment: String,
        /// What is wrong.
        message: String,
    },
    /// A plugin name that no crate registered.
    #[error("unknown {role} model `{name}` at {path}; registered {role} models: {choices}{hint}")]
    UnknownPlugin {
        /// Role of the plugin ("stress", "exchange", "pressure", "frame").
        role: &'static str,
        /// The name given.
        name: String,
        /// Where it was given.
        path: String,
        /// Comma-separated registered names.
        choices: String,
        /// "; did you mean `x`?" or empty.
        hint: String,
    },
    /// The pressure solve did not converge.
    #[error("pressure solver `{solver}` did not reach the relative residual {tolerance:e} in {iterations} iterations (reached {residual:e}); residual history (every 10th): {history}")]
    SolverDiverged {
        /// Solver name.
        solver: String,
        /// Requested tolerance.
        tolerance: f64,
        /// Iterations done.
        iterations: usize,
        /// Final relative residual.
        residual: f64,
        /// Abbreviated residual history.
        history: String,
    },
    /// A model failed during the run.
    #[error("{0}")]
    Model(String),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Result with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Invalid`] for a case built in code.
    pub fn invalid(path: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid { file: PathBuf::from("<case>"), path: path.into(), message: message.into() }
    }
    /// Attaches the case file name to an [`Error::Invalid`].
    pub fn in_file(self, file: &std::path::Path) -> Self {
        match self {
            Error::Invalid { path, message, .. } => Error::Invalid { file: file.to_path_buf(), path, message },
            other => other,
        }
    }
}

/// Levenshtein distance, for "did you mean" hints.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// `"; did you mean `x`?"` for the closest of `choices`, or empty when none is close.
pub fn did_you_mean<'a>(name: &str, choices: impl IntoIterator<Item = &'a str>) -> String {
    choices
        .into_iter()
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, c)| *d <= (c.len() / 3).max(2))
        .min()
        .map(|(_, c)| format!("; did you mean `{c}`?"))
        .unwrap_or_default()
}
