//! Errors for bad input: each names the field, the value and what is allowed.

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
}

impl InputError {
    /// An [`InputError::Invalid`] for a number.
    pub fn invalid(field: impl Into<String>, value: f64, allowed: impl Into<String>) -> InputError {
        // Plain notation unless that would print hundreds of digits.
        let text = if value == 0.0 || !value.is_finite() || (1e-6..1e15).contains(&value.abs()) {
            format!("{value}")
        } else {
            format!("{value:e}")
        };
        InputError::Invalid { field: field.into(), value: text, allowed: allowed.into() }
    }
}

/// Longest name or description a file may give (characters).
pub const MAX_NAME_CHARS: usize = 200;

/// Checks a name or description is printable text of at most
/// [`MAX_NAME_CHARS`] characters: it goes into titles, SVG text and
/// one-line messages, where control characters break them.
pub fn printable(field: &str, text: &str) -> Result<(), InputError> {
    if text.chars().count() <= MAX_NAME_CHARS && !text.chars().any(char::is_control) {
        return Ok(());
    }
    let shown: String = text.chars().take(40).flat_map(char::escape_default).collect();
    Err(InputError::Invalid {
        field: field.into(),
        value: format!("\"{shown}\"{}", if text.chars().count() > 40 { "..." } else { "" }),
        allowed: format!("printable text (no control characters) of at most {MAX_NAME_CHARS} characters"),
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
        Err(InputError::invalid(field, value, format!("a finite number in [{lo}, {hi}]")))
    }
}
