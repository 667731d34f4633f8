//! The vocabulary of the diagnosis: the types it names, the defect families it reads,
//! one family's evidence, and the constants of the band search and the lines.

use crate::bearing::DefectOrders;

/// Lowest edge of the bands searched, Hz: above the shaft harmonics and the
/// low-frequency structure.
pub const BAND_LO_HZ: f32 = 400.0;
/// Narrowest band searched, Hz.
pub const MIN_BAND_HZ: f32 = 1_200.0;
/// The band is at least this many times the highest family's fundamental wide.
pub const LINES_PER_BAND: f32 = 3.5;
/// Harmonics of each defect family read.
pub const HARMONICS: usize = 3;
/// Relative tolerance of a line's frequency per harmonic (slip of real bearings: 1–2 %).
pub const SLIP: f32 = 0.02;
/// Most bands searched in one window.
pub const MAX_BANDS: usize = 32;

/// The diagnosed type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultType {
    /// No defect line and no impulsiveness.
    Normal,
    /// Inner-race defect (BPFI family).
    InnerRace,
    /// Outer-race defect (BPFO family).
    OuterRace,
    /// Rolling-element defect (2·BSF family).
    Ball,
    /// Evidence of something (impulsiveness, or two families tied), but no defect's
    /// lines stand out of the others.
    NoClearSignature,
}

impl FaultType {
    /// Every type, in a fixed order.
    pub const ALL: [FaultType; 5] = [
        FaultType::Normal,
        FaultType::InnerRace,
        FaultType::OuterRace,
        FaultType::Ball,
        FaultType::NoClearSignature,
    ];

    /// Its name in reports: `normal`, `inner_race`, `outer_race`, `ball`,
    /// `no_clear_signature`.
    pub const fn name(self) -> &'static str {
        match self {
            FaultType::Normal => "normal",
            FaultType::InnerRace => "inner_race",
            FaultType::OuterRace => "outer_race",
            FaultType::Ball => "ball",
            FaultType::NoClearSignature => "no_clear_signature",
        }
    }

    /// The type named `name` (as [`FaultType::name`] writes it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The type a network's class name stands for: the CWRU size classes `IR…`,
    /// `OR…`, `B…` and `normal`; `None` for any other name.
    pub fn of_class(class: &str) -> Option<Self> {
        if class.starts_with("IR") {
            Some(FaultType::InnerRace)
        } else if class.starts_with("OR") {
            Some(FaultType::OuterRace)
        } else if class.starts_with('B') {
            Some(FaultType::Ball)
        } else if class == "normal" {
            Some(FaultType::Normal)
        } else {
            None
        }
    }
}

/// How a network's type and the physics' type of the same stretch disagree, where it
/// matters to a reader: what the physics can support decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Disagreement {
    /// The network names a fault where the drive end shows no defect line and no
    /// impulsiveness: outside its training conditions (noise, another machine, a
    /// wrong speed or rate), its class is not supported.
    Unsupported,
    /// The physics names a defect and the network another type (another defect, or
    /// normal): the physics' lines decide.
    Different,
}

impl Disagreement {
    /// The disagreement of `network` with `physics`, if any (`NoClearSignature` on
    /// either side supports or refutes nothing).
    ///
    /// ```
    /// use pumptwin_core::diagnosis::{Disagreement, FaultType::*};
    /// assert_eq!(Disagreement::of(Ball, Normal), Some(Disagreement::Unsupported));
    /// assert_eq!(Disagreement::of(Normal, InnerRace), Some(Disagreement::Different));
    /// assert_eq!(Disagreement::of(InnerRace, OuterRace), Some(Disagreement::Different));
    /// assert_eq!(Disagreement::of(InnerRace, InnerRace), None);
    /// assert_eq!(Disagreement::of(InnerRace, NoClearSignature), None);
    /// assert_eq!(Disagreement::of(Normal, Normal), None);
    /// ```
    pub fn of(network: FaultType, physics: FaultType) -> Option<Self> {
        use FaultType::{Ball, InnerRace, Normal, OuterRace};
        let defect = |t| matches!(t, InnerRace | OuterRace | Ball);
        match (network, physics) {
            (n, Normal) if defect(n) => Some(Self::Unsupported),
            (n, p) if defect(p) && n != p && n != FaultType::NoClearSignature => {
                Some(Self::Different)
            }
            _ => None,
        }
    }
}

/// A defect family: the lines one defect puts into the squared envelope.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Defect {
    /// Outer race: BPFO and harmonics.
    Outer,
    /// Inner race: BPFI and harmonics.
    Inner,
    /// Rolling element: 2·BSF and harmonics.
    Ball,
}

impl Defect {
    /// The three families, in a fixed order.
    pub const ALL: [Defect; 3] = [Defect::Outer, Defect::Inner, Defect::Ball];

    /// Fundamental of the family in orders of the shaft rate.
    pub fn order(self, orders: &DefectOrders) -> f32 {
        match self {
            Defect::Outer => orders.bpfo,
            Defect::Inner => orders.bpfi,
            Defect::Ball => 2.0 * orders.bsf,
        }
    }

    /// The type a claim of this family makes.
    pub const fn fault_type(self) -> FaultType {
        match self {
            Defect::Outer => FaultType::OuterRace,
            Defect::Inner => FaultType::InnerRace,
            Defect::Ball => FaultType::Ball,
        }
    }
}

/// The evidence of one family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineEvidence {
    /// Mean of the family's harmonics over the SES median, dB.
    pub level_db: f32,
    /// Impact power against the band's background, dB (see the module docs).
    pub impact_to_background_db: f32,
    /// Its standard uncertainty from the SES scatter, dB.
    pub uncertainty_db: f32,
    /// How far the second and third lines' mean power falls below the first's in
    /// the SES, dB (positive: they are weaker); grows with the defect's width (see
    /// the module docs of `crate::diagnosis`).
    pub harmonic_fall_db: f32,
    /// Its standard uncertainty from the SES scatter, dB.
    pub fall_uncertainty_db: f32,
    /// Whether the second and third lines both stand above their noise: where they
    /// do not, the fall is read short and reads no width.
    pub fall_lines_clear: bool,
    /// The band's own pulse power at the family's second and third harmonic over
    /// its first (`pulse_transfer_of`): the fall the ring-down and the
    /// band make whatever the defect's width, which the width read from the fall
    /// takes out.
    pub pulse_transfer: [f32; 2],
}

impl LineEvidence {
    /// No evidence.
    pub const NONE: Self = Self {
        level_db: 0.0,
        impact_to_background_db: 0.0,
        uncertainty_db: 0.0,
        harmonic_fall_db: 0.0,
        fall_uncertainty_db: 0.0,
        fall_lines_clear: false,
        pulse_transfer: [1.0, 1.0],
    };
}
