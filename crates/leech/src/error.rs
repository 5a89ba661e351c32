//! Errors for bad input: each names the field, the value and what is allowed;
//! and a situation's failure (bad input, or a solve's).

use crate::statics::SolveError;

/// User input that cannot describe a robot or a solve.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InputError {
    /// A value outside its allowed range.
    #[error("{field}: got {value}, expected {allowed}")]
    Invalid {
        /// Dotted name of the field (`tube.element_length_m`, `--lengths`).
        field: String,
        /// The value given, as text.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A robot file that is not valid TOML or has unknown or missing keys.
    #[error("robot file: {message}")]
    Toml {
        /// The parser's message, folded to one line.
        message: String,
    },
    /// A named file (a scene) that is not valid TOML or has unknown or missing keys.
    #[error("{file}: {message}")]
    File {
        /// Where the text came from (a path or a built-in name).
        file: String,
        /// The parser's message with its line, on one line.
        message: String,
    },
    /// A file a user named that cannot be read or written as asked (see
    /// [`crate::files`]): missing, a directory, too large, not text.
    #[error("{field}: got {file}, {problem}; expected {allowed}")]
    Unreadable {
        /// The flag or field that named it (`--robot`).
        field: String,
        /// The path, quoted, escaped and clipped (see [`clip`]).
        file: String,
        /// What is wrong, as a clause on the path (`which is larger than 1 MiB`).
        problem: String,
        /// What is allowed (`a robot file of at most 1 MiB`).
        allowed: String,
    },
}

impl InputError {
    /// An [`InputError::Invalid`] for a number.
    pub fn invalid(field: impl Into<String>, value: f64, allowed: impl Into<String>) -> InputError {
        InputError::Invalid { field: field.into(), value: Num(value).to_string(), allowed: allowed.into() }
    }

    /// This error as the flag `flag` (`--lengths`) gave the value: a user
    /// must find the flag they typed, not only the library's name for the
    /// field. A field spelling the flag's words (`lengths[0] (LA)`, `shape
    /// parameter`, `angle (deg)`) takes the flag's spelling (`--lengths[0]
    /// (LA)`); another keeps its name after the flag (`--base-angle
    /// (world.base_angle_deg)`). Parse errors of files are left as they are.
    ///
    /// ```
    /// use leech::error::InputError;
    /// let named = |field: &str, flag| InputError::invalid(field, 1.0, "x").for_flag(flag).to_string();
    /// assert_eq!(named("lengths[0] (LA)", "--lengths"), "--lengths[0] (LA): got 1, expected x");
    /// assert_eq!(named("shape parameter", "--shape-parameter"), "--shape-parameter: got 1, expected x");
    /// assert_eq!(named("world.base_angle_deg", "--base-angle"), "--base-angle (world.base_angle_deg): got 1, expected x");
    /// assert_eq!(named("lengths range", "--lengths"), "--lengths (lengths range): got 1, expected x");
    /// assert_eq!(named("--ramp", "--ramp"), "--ramp: got 1, expected x");
    /// ```
    pub fn for_flag(self, flag: &str) -> InputError {
        match self {
            InputError::Invalid { field, value, allowed } => {
                InputError::Invalid { field: flag_field(flag, &field), value, allowed }
            }
            InputError::Unreadable { field, file, problem, allowed } => {
                InputError::Unreadable { field: flag_field(flag, &field), file, problem, allowed }
            }
            other => other,
        }
    }
}

/// `field` named by `flag` (see [`InputError::for_flag`]).
fn flag_field(flag: &str, field: &str) -> String {
    if field.starts_with(flag) {
        return field.to_string();
    }
    // The flag's words, `-` between them, against the field's, ` ` or `_` between them.
    let words = flag.trim_start_matches('-');
    let mut rest = field.chars();
    let spelt = words.chars().all(|w| match rest.next() {
        Some(f) => f == w || (w == '-' && (f == ' ' || f == '_')),
        None => false,
    });
    let rest = rest.as_str();
    // Only where the field's name ends: `lengths range` is not `--lengths`.
    if spelt && (rest.is_empty() || rest.starts_with('[') || rest.starts_with(" (")) {
        format!("{flag}{rest}")
    } else {
        format!("{flag} ({field})")
    }
}

/// A number as messages print it: the shortest text that reads back to it
/// (`0.25`, `-3`), in scientific notation (`1e308`, `2.5e-9`) beyond 1e6 or
/// below 1e-4 in magnitude, where plain notation would run to hundreds of
/// digits.
///
/// ```
/// use leech::error::Num;
/// assert_eq!(Num(0.25).to_string(), "0.25");
/// assert_eq!(Num(1e308).to_string(), "1e308");
/// assert_eq!(Num(-2.5e-9).to_string(), "-2.5e-9");
/// assert_eq!(Num(f64::INFINITY).to_string(), "inf");
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl Num {
    /// `x` rounded to `digits` significant digits (at least 1), for a label
    /// that must stay short whatever the value's scale.
    ///
    /// ```
    /// use leech::error::Num;
    /// assert_eq!(Num::rounded(0.05, 3).to_string(), "0.05");
    /// assert_eq!(Num::rounded(100.0 / 3.0, 3).to_string(), "33.3");
    /// assert_eq!(Num::rounded(2.0e7 / 3.0, 2).to_string(), "6.7e6");
    /// ```
    pub fn rounded(x: f64, digits: usize) -> Num {
        // Rust prints the shortest decimal that reads back exactly, so the
        // rounded value prints with no more digits than asked for.
        let text = format!("{x:.*e}", digits.max(1) - 1);
        Num(text.parse().unwrap_or(x))
    }
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// Most characters of a user's text a message quotes: enough to find the
/// spot, never a file's worth.
pub const EXCERPT_CHARS: usize = 40;

/// Most characters of a parser's message a message passes on: the parser
/// may quote a user's text in it (an unknown key), at any length.
pub const MESSAGE_CHARS: usize = 240;

/// At most `max` characters of `text`, escaped as Rust's `{:?}` does but
/// for quotes (no NUL, control characters or byte-order marks reach a
/// terminal), `...` after a cut: a message passes a user's bytes on only
/// this way.
///
/// ```
/// use leech::error::clip;
/// assert_eq!(clip("a\u{0}b\u{feff}", 40), "a\\0b\\u{feff}");
/// assert_eq!(clip(&"[".repeat(10_000), 3), "[[[...");
/// ```
pub fn clip(text: &str, max: usize) -> String {
    let mut out = String::new();
    for (i, c) in text.chars().enumerate() {
        if i == max {
            out.push_str("...");
            break;
        }
        match c {
            c if invisible(c) => out.extend(c.escape_unicode()),
            '"' | '\'' => out.push(c),
            _ => out.extend(c.escape_debug()),
        }
    }
    out
}

/// `text` quoted for a message: at most [`EXCERPT_CHARS`] characters,
/// escaped (see [`clip`]), in single quotes as the command line's messages
/// quote what a user gave.
///
/// ```
/// use leech::error::quoted;
/// assert_eq!(quoted("1.2.3"), "'1.2.3'");
/// assert_eq!(quoted("x\ty'"), "'x\\ty\\''");
/// ```
pub fn quoted(text: &str) -> String {
    format!("'{}'", clip(text, EXCERPT_CHARS).replace('\'', "\\'"))
}

/// Whether `c` is printable but invisible, or reorders what follows it (a
/// byte-order mark, zero-width and bidirectional marks, overrides and
/// isolates): text shown to a user never carries one as it is.
pub fn invisible(c: char) -> bool {
    matches!(c, '\u{feff}' | '\u{061c}' | '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2060}'..='\u{2069}')
}

/// Longest name or description a file may give (characters).
pub const MAX_NAME_CHARS: usize = 200;

/// Checks a name or description is printable text of at most
/// [`MAX_NAME_CHARS`] characters: it goes into titles, SVG text and
/// one-line messages, where control characters break them and invisible
/// ones ([`invisible`]: a right-to-left override) disguise them.
pub fn printable(field: &str, text: &str) -> Result<(), InputError> {
    if text.chars().count() <= MAX_NAME_CHARS && !text.chars().any(|c| c.is_control() || invisible(c)) {
        return Ok(());
    }
    Err(InputError::Invalid {
        field: field.into(),
        value: quoted(text),
        allowed: format!(
            "printable text (no control, invisible or bidirectional characters) of at most {MAX_NAME_CHARS} characters"
        ),
    })
}

/// Checks `value` is finite and strictly positive.
pub fn positive(field: &str, value: f64) -> Result<f64, InputError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(InputError::invalid(field, value, "a finite number > 0"))
    }
}

/// Checks `value` is finite and not negative.
pub fn non_negative(field: &str, value: f64) -> Result<f64, InputError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(InputError::invalid(field, value, "a finite number >= 0"))
    }
}

/// Checks `value` is finite and within `[lo, hi]`.
pub fn within(field: &str, value: f64, lo: f64, hi: f64) -> Result<f64, InputError> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(value)
    } else {
        Err(InputError::invalid(field, value, format!("a finite number in [{}, {}]", Num(lo), Num(hi))))
    }
}

/// A job that had bad input, or that its [`Deadline`](crate::budget::Deadline)
/// stopped first: what a workspace sweep and an inverse solve return (each
/// names it after itself, `SweepError`, `ReachError`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum JobError {
    /// Bad options or robot.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The deadline ran out (or the job was cancelled) first.
    #[error("stopped: {0}")]
    Stopped(#[from] crate::budget::Stopped),
}

/// The parser's message with its line number, folded to one line (the
/// parser's own text spans several lines and draws a caret under the spot),
/// escaped and cut short: it may quote the file's bytes (an unknown key).
/// Shared by robot, scene and scenario files. A message that names no key
/// (a wrong type, a duplicate) gets the key of its line, dotted under its
/// table (`tube.element_length_m`), and reads in the house format: `line 9:
/// tube.element_length_m: got string "ten", expected a number`.
pub(crate) fn one_line(text: &str, error: &toml::de::Error) -> String {
    let folded = house(&error.message().split_whitespace().collect::<Vec<_>>().join(" "));
    let message = clip(&folded, MESSAGE_CHARS);
    let Some(span) = error.span() else { return message };
    let start = span.start.min(text.len());
    let line = text[..start].matches('\n').count() + 1;
    // A message that names the key already ("unknown field `colour`") is not
    // told it twice; one that only quotes the value ("got integer `1`") is.
    let named = |key: &String| folded.contains(&format!("`{}`", key.rsplit('.').next().unwrap_or(key)));
    match key_at(text, start).filter(|key| !named(key)) {
        Some(key) => format!("line {line}: {}: {message}", clip(&key, EXCERPT_CHARS)),
        None => format!("line {line}: {message}"),
    }
}

/// The key written on the line of byte `at` of a TOML `text`, dotted under
/// the table it is in (`tube.element_length_m`), or the table header itself
/// (`[world]`); none on a line without a key (an array running on).
fn key_at(text: &str, at: usize) -> Option<String> {
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    let code = line.split('#').next().unwrap_or("").trim();
    if code.starts_with('[') {
        return Some(code.to_string());
    }
    let key = code.split_once('=')?.0.trim();
    if key.is_empty() {
        return None;
    }
    // The last table header above the line.
    let table = text[..line_start].lines().rev().find_map(|l| {
        let l = l.split('#').next().unwrap_or("").trim();
        l.starts_with('[').then(|| l.trim_matches(['[', ']']).trim().to_string())
    });
    Some(match table {
        Some(table) => format!("{table}.{key}"),
        None => key.to_string(),
    })
}

/// A serde or TOML message in the house format (`got ..., expected ...`),
/// Rust's type names as a user's (`f64`: a number), each backquoted key
/// clipped (an unknown key may be a file's worth).
fn house(message: &str) -> String {
    let message = if let Some(rest) = message.strip_prefix("invalid type: ") {
        format!("got {rest}")
    } else if let Some(rest) = message.strip_prefix("invalid length ") {
        format!("got length {rest}")
    } else if message == "duplicate key" {
        "got it a second time, expected each key and table once".to_string()
    } else {
        message.to_string()
    };
    let message = match message.rsplit_once(", expected ") {
        Some((got, expected)) => {
            let expected = match expected {
                "f64" | "f32" => "a number",
                "u8" | "u16" | "u32" | "u64" | "usize" => "a whole number >= 0",
                "i8" | "i16" | "i32" | "i64" | "isize" => "a whole number",
                "a sequence" => "an array",
                other => other,
            };
            format!("{got}, expected {expected}")
        }
        None => message,
    };
    // Odd-numbered pieces between backquotes are keys.
    message
        .split('`')
        .enumerate()
        .map(|(i, piece)| if i % 2 == 1 { clip(piece, EXCERPT_CHARS) } else { piece.into() })
        .collect::<Vec<_>>()
        .join("`")
}

/// Why a situation (a body held by its cups, among solids; [`crate::stance`],
/// [`crate::body3`]) could not be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StanceError {
    /// Bad input.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A solve that did not converge.
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// Both holds, the front one farther from the driving unit than chain A
    /// reaches: the solve failed, as it must (no stretched body).
    #[error("front hold out of reach: {distance_m:.4} m from the driving unit, chain A (tube 1) reaches at most {reach_m:.4} m ({source})")]
    OutOfReach {
        /// Distance from chain A's clamp to the front hold's point (m).
        distance_m: f64,
        /// Chain A's tube length (m).
        reach_m: f64,
        /// How the solve failed.
        source: SolveError,
    },
}
