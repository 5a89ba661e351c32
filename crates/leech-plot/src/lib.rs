//! # leech-plot: pictures of leech results
//!
//! A [`Figure`] is a list of [`Series`] (polylines and markers in metres)
//! drawn with axes in millimetres, an equal aspect ratio (a shape must not be
//! distorted), a legend and, optionally, an arrow showing gravity's direction.
//! It renders to SVG or PNG with an embedded font, so it works on a machine
//! without system fonts.
//!
//! [`shape`] builds the standard pictures of a body and of a single tube,
//! [`body3`] the three-tube body's three views with a scene and its cups,
//! [`stance`] a held body among a scene's solids with its cups and forces,
//! [`climb`] a planned climb as an animated SVG (one frame per step);
//! [`figures`] regenerates the paper's figures with their data.
//!
//! ```
//! use leech::prelude::*;
//! let robot = Robot::builtin();
//! let body = robot.body(0.25, 0.22).unwrap();
//! let eq = body.solve(&Solver::default()).unwrap();
//! let figure = leech_plot::shape::body_figure(&robot.name, &body, &eq.q);
//! let svg = figure.to_svg_string().unwrap();
//! assert!(svg.starts_with("<svg") && svg.contains("chain A"));
//! ```

#![warn(missing_docs)]

pub mod animation;
pub mod body3;
pub mod climb;
pub mod figure;
pub mod figures;
pub mod shape;
pub mod stance;

pub use figure::{Axes, Figure, PlotError, Series, SeriesStyle};
