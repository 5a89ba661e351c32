//! The websocket's messages: JSON objects tagged by `type`, units in the
//! field names (`_m` metres, `_mm` millimetres, `_n` newtons, `_kpa`,
//! `_ms`, `_s`, `_rad`).
//!
//! A tab sends [`Request`]s; the server answers each refused one with an
//! [`Refusal`] naming the field, the value it got and what is allowed, and
//! sends every tab the [`crate::console::Snapshot`] many times a second.

use serde::{Deserialize, Serialize};

/// The largest text message a tab may send (bytes): every request is a
/// few hundred bytes at most.
pub const MAX_REQUEST_BYTES: usize = 4096;

/// A cup by its name on the page.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CupName {
    /// The cup on the driving unit.
    Rear,
    /// The cup on the endpoint plate.
    Front,
}

/// How much of the plan to carry out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Execute {
    /// The next step only.
    Step,
    /// Every step left.
    All,
}

/// What a tab asks for.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    /// Become the driver (only one tab drives).
    TakeControl {},
    /// Stop driving; another tab may take control.
    ReleaseControl {},
    /// Move the tubes L1, L2, L3 to these lengths (m).
    SetLengths {
        /// Targets (m).
        lengths_m: [f64; 3],
    },
    /// Move one tube (1, 2 or 3) by a distance (mm, positive lengthens).
    Jog {
        /// The tube's number.
        tube: u8,
        /// The distance (mm).
        delta_mm: f64,
    },
    /// Switch a cup's pump.
    Pump {
        /// The cup.
        cup: CupName,
        /// On or off.
        on: bool,
    },
    /// One phase of a stride by hand (`push`, `attach_front`, ...); a move
    /// (`push`, `pull`) takes the lengths LA, LB (m).
    Stride {
        /// The phase's name.
        phase: String,
        /// LA, LB for a move (m).
        #[serde(default)]
        lengths_m: Option<[f64; 2]>,
    },
    /// Halt every motor at once (any tab may).
    Stop {},
    /// The lengths that put the front cup's face on the surface nearest a
    /// point of the scene, and the body they predict (nothing moves).
    Reach {
        /// The point clicked (m).
        point_m: [f64; 2],
    },
    /// Plan a climb from where the rear cup holds to a goal: a built-in
    /// scenario's (on the console's scene), or a point and a tolerance.
    Plan {
        /// A built-in scenario's name (`leech scenario list`).
        #[serde(default)]
        scenario: Option<String>,
        /// Where the rear cup's face centre should land (m).
        #[serde(default)]
        goal_m: Option<[f64; 2]>,
        /// How close it must come (m).
        #[serde(default)]
        tolerance_m: Option<f64>,
    },
    /// Carry out the planned climb.
    Execute {
        /// The next step or all of them.
        mode: Execute,
    },
    /// The reachable endpoints from where the driving unit is, for the overlay.
    Workspace {},
}

impl Request {
    /// Every request's `type`, as the protocol spells it. (Variants without
    /// fields are written `{}`: serde refuses unknown fields only in those.)
    pub const TYPES: [&'static str; 12] = [
        "take_control",
        "release_control",
        "set_lengths",
        "jog",
        "pump",
        "stride",
        "stop",
        "reach",
        "plan",
        "execute",
        "workspace",
        "ping",
    ];

    /// Its `type`.
    pub fn name(&self) -> &'static str {
        match self {
            Request::TakeControl {} => "take_control",
            Request::ReleaseControl {} => "release_control",
            Request::SetLengths { .. } => "set_lengths",
            Request::Jog { .. } => "jog",
            Request::Pump { .. } => "pump",
            Request::Stride { .. } => "stride",
            Request::Stop {} => "stop",
            Request::Reach { .. } => "reach",
            Request::Plan { .. } => "plan",
            Request::Execute { .. } => "execute",
            Request::Workspace {} => "workspace",
        }
    }
}

/// Why a request was refused: which field, what it held, what is allowed.
#[derive(Clone, Debug, PartialEq, Serialize, thiserror::Error)]
#[error("{request}: {field} = {value}: {message} (allowed: {allowed})")]
pub struct Refusal {
    /// The request's type (`"message"` when it could not be read).
    pub request: String,
    /// The field at fault.
    pub field: String,
    /// What it held.
    pub value: String,
    /// What would be accepted.
    pub allowed: String,
    /// Why, in a sentence.
    pub message: String,
}

impl Refusal {
    /// A refusal of `request`'s `field`.
    pub fn new(
        request: &str,
        field: &str,
        value: impl std::fmt::Display,
        allowed: impl Into<String>,
        message: impl Into<String>,
    ) -> Refusal {
        Refusal {
            request: request.into(),
            field: field.into(),
            value: value.to_string(),
            allowed: allowed.into(),
            message: message.into(),
        }
    }
}

/// A piece of text cut to at most `n` characters (a refusal quotes what it got).
pub fn excerpt(text: &str, n: usize) -> String {
    let mut cut: String = text.chars().take(n).collect();
    if cut.len() < text.len() {
        cut.push_str("...");
    }
    cut
}

/// Reads one text message: JSON, an object with a known `type`, and the
/// fields that type takes (unknown fields refused), or a refusal saying
/// which part is wrong. `ping` is answered by the caller and comes back as
/// `Ok(None)`.
pub fn parse(text: &str) -> Result<Option<Request>, Refusal> {
    if text.len() > MAX_REQUEST_BYTES {
        return Err(Refusal::new(
            "message",
            "length",
            format!("{} bytes", text.len()),
            format!("at most {MAX_REQUEST_BYTES} bytes"),
            "the message is too long",
        ));
    }
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        Refusal::new("message", "json", excerpt(text, 80), "a JSON object with a \"type\"", format!("not JSON: {e}"))
    })?;
    let Some(kind) = value.get("type").and_then(|t| t.as_str()) else {
        return Err(Refusal::new(
            "message",
            "type",
            excerpt(&value.get("type").map_or("missing".into(), |t| t.to_string()), 80),
            Request::TYPES.join(", "),
            "every message is a JSON object with a \"type\" string",
        ));
    };
    if kind == "ping" {
        return Ok(None);
    }
    if !Request::TYPES.contains(&kind) {
        return Err(Refusal::new(
            "message",
            "type",
            format!("{:?}", excerpt(kind, 40)),
            Request::TYPES.join(", "),
            "unknown message type",
        ));
    }
    let kind = kind.to_string();
    serde_json::from_value(value).map(Some).map_err(|e| {
        Refusal::new(
            &kind,
            "fields",
            excerpt(text, 120),
            "the fields of this type, each a number, string or boolean as documented",
            format!("bad fields: {e}"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_read_and_bad_ones_named() {
        let r = parse(r#"{"type":"set_lengths","lengths_m":[0.1,0.2,0.2]}"#).unwrap();
        assert_eq!(r, Some(Request::SetLengths { lengths_m: [0.1, 0.2, 0.2] }));
        assert_eq!(parse(r#"{"type":"ping"}"#).unwrap(), None);
        assert_eq!(parse("{").unwrap_err().field, "json");
        assert_eq!(parse("[1]").unwrap_err().field, "type");
        assert_eq!(parse(r#"{"type":"fly"}"#).unwrap_err().message, "unknown message type");
        let extra = parse(r#"{"type":"stop","force":true}"#).unwrap_err();
        assert_eq!((extra.request.as_str(), extra.field.as_str()), ("stop", "fields"));
        assert!(parse(r#"{"type":"jog","tube":1,"delta_mm":NaN}"#).is_err());
        assert!(parse(&"x".repeat(MAX_REQUEST_BYTES + 1)).is_err());
        for t in Request::TYPES.iter().filter(|t| **t != "ping") {
            // Every listed type is a request (its fields aside).
            let e = parse(&format!(r#"{{"type":"{t}"}}"#));
            assert!(e.is_ok() || e.unwrap_err().field == "fields", "{t}");
        }
    }
}
