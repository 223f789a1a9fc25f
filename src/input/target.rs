//! The integrals a method approximates and a reference computes (docs/conventions.md).

use serde::{Deserialize, Serialize};
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    /// Eq. 1.6: `∫ D(ω_p) 2‖ω_p × ω_t‖/‖p‖² dl`.
    Line,
    /// `line` with `D(ω)·[ω.z > 0]`: what a real surface receives.
    LineUpper,
    /// `∫ D(ω_p)/‖p‖² dl`: isotropic point emitters of unit intensity per unit length (the
    /// model Unreal Engine 4 and O3DE shade); `line` differs by the width `2‖ω_p × ω_t‖`.
    LineIsotropic,
    /// `line` of the material's D plus a white Lambertian base `max(0, ω.z)/π` (weights 1
    /// and 1): what a method summing a diffuse and a specular term approximates.
    LineSum,
    /// `line_isotropic` of the same sum.
    LineIsotropicSum,
    /// Eq. 1.2 over the tube's side, radius R.
    Cylinder,
    /// Eq. 1.29 for both end disks.
    Caps,
    /// `cylinder + caps`.
    Tube,
    /// Thin two-sided rectangle centred on the segment.
    Rectangle,
}

impl Target {
    pub const ALL: [Target; 9] = [
        Target::Line,
        Target::LineUpper,
        Target::LineIsotropic,
        Target::LineSum,
        Target::LineIsotropicSum,
        Target::Cylinder,
        Target::Caps,
        Target::Tube,
        Target::Rectangle,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::Line => "line",
            Target::LineUpper => "line_upper",
            Target::LineIsotropic => "line_isotropic",
            Target::LineSum => "line_sum",
            Target::LineIsotropicSum => "line_isotropic_sum",
            Target::Cylinder => "cylinder",
            Target::Caps => "caps",
            Target::Tube => "tube",
            Target::Rectangle => "rectangle",
        }
    }

    pub fn from_name(s: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == s)
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
