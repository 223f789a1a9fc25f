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
    /// `cylinder` with `D(ω)·[ω.z > 0]`: what a real surface receives from the tube's side
    /// (as `line_upper` is to `line`).
    CylinderUpper,
    /// `caps` with `D(ω)·[ω.z > 0]`.
    CapsUpper,
    /// `cylinder_upper + caps_upper`.
    TubeUpper,
    /// `rectangle` with `D(ω)·[ω.z > 0]`.
    RectangleUpper,
}

impl Target {
    pub const ALL: [Target; 13] = [
        Target::Line,
        Target::LineUpper,
        Target::LineIsotropic,
        Target::LineSum,
        Target::LineIsotropicSum,
        Target::Cylinder,
        Target::Caps,
        Target::Tube,
        Target::Rectangle,
        Target::CylinderUpper,
        Target::CapsUpper,
        Target::TubeUpper,
        Target::RectangleUpper,
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
            Target::CylinderUpper => "cylinder_upper",
            Target::CapsUpper => "caps_upper",
            Target::TubeUpper => "tube_upper",
            Target::RectangleUpper => "rectangle_upper",
        }
    }

    /// What a real surface receives of this target: `D(ω)·[ω.z > 0]` (`line` → `line_upper`,
    /// `cylinder` → `cylinder_upper`, …). None for targets that have no clipped variant.
    pub fn upper(self) -> Option<Target> {
        match self {
            Target::Line | Target::LineUpper => Some(Target::LineUpper),
            Target::Cylinder | Target::CylinderUpper => Some(Target::CylinderUpper),
            Target::Caps | Target::CapsUpper => Some(Target::CapsUpper),
            Target::Tube | Target::TubeUpper => Some(Target::TubeUpper),
            Target::Rectangle | Target::RectangleUpper => Some(Target::RectangleUpper),
            Target::LineIsotropic | Target::LineSum | Target::LineIsotropicSum => None,
        }
    }

    /// The target whose lobe is not clipped at the surface (`line_upper` → `line`, …); itself
    /// for the others.
    pub fn own(self) -> Target {
        match self {
            Target::LineUpper => Target::Line,
            Target::CylinderUpper => Target::Cylinder,
            Target::CapsUpper => Target::Caps,
            Target::TubeUpper => Target::Tube,
            Target::RectangleUpper => Target::Rectangle,
            t => t,
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
