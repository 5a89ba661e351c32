//! The library of built-in scenes: TOML files under `crates/leech/scenes/`,
//! compiled in, each commented with where its dimensions come from.
//!
//! Floor scenes put the rear cup at the origin facing +x; wall scenes put it on
//! the wall at the origin facing up.

use super::Scene;
use crate::error::InputError;

/// A scene shipped with the library.
#[derive(Clone, Copy, Debug)]
pub struct BuiltinScene {
    /// The name [`Scene::builtin`] takes.
    pub name: &'static str,
    /// One line saying what it is.
    pub description: &'static str,
    /// The scene file, comments included.
    pub toml: &'static str,
}

/// Every built-in scene, simplest first.
pub const BUILTIN_SCENES: [BuiltinScene; 6] = [
    BuiltinScene {
        name: "floor",
        description: "a level floor: solid below y = 0",
        toml: include_str!("../../scenes/floor.toml"),
    },
    BuiltinScene {
        name: "wall",
        description: "a vertical wall to climb: solid at x >= 0, the robot on its face",
        toml: include_str!("../../scenes/wall.toml"),
    },
    BuiltinScene {
        name: "floor-to-wall",
        description: "a floor meeting a wall 0.20 m ahead in an inside corner (estimated distance)",
        toml: include_str!("../../scenes/floor-to-wall.toml"),
    },
    BuiltinScene {
        name: "step",
        description: "a floor with a 0.10 m step up 0.20 m ahead (estimated)",
        toml: include_str!("../../scenes/step.toml"),
    },
    BuiltinScene {
        name: "thin-wall",
        description: "a wall 20 mm thick and 0.25 m high on a floor, 0.20 m ahead (estimated)",
        toml: include_str!("../../scenes/thin-wall.toml"),
    },
    BuiltinScene {
        name: "ceiling",
        description: "a vertical wall meeting a ceiling 0.25 m above the rear cup (estimated)",
        toml: include_str!("../../scenes/ceiling.toml"),
    },
];

impl Scene {
    /// The built-in scene called `name` (see [`BUILTIN_SCENES`]).
    pub fn builtin(name: &str) -> Result<Scene, InputError> {
        match BUILTIN_SCENES.iter().find(|s| s.name == name) {
            Some(s) => Scene::from_toml_str(s.toml, &format!("built-in scene {name}")),
            None => Err(InputError::Invalid {
                field: "scene".into(),
                value: format!("{name:?}"),
                allowed: format!("one of {}", Scene::builtin_names().map(|(n, _)| n).collect::<Vec<_>>().join(", ")),
            }),
        }
    }

    /// The built-in scenes' names with their one-line descriptions.
    pub fn builtin_names() -> impl Iterator<Item = (&'static str, &'static str)> {
        BUILTIN_SCENES.iter().map(|s| (s.name, s.description))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_unknown_names_list_them() {
        for (name, description) in Scene::builtin_names() {
            let scene = Scene::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(!scene.solids.is_empty() && !description.contains('\n'));
        }
        let e = Scene::builtin("cliff").unwrap_err().to_string();
        assert!(e.contains("\"cliff\"") && e.contains("thin-wall"), "{e}");
    }
}
