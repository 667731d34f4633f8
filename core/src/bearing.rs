//! Rolling-bearing kinematics: the defect frequencies that set `T_impact` in eq. 18.
//!
//! For a bearing with `n` rolling elements of diameter `d` on pitch diameter `D` with
//! contact angle `φ`, stationary outer race and shaft rate `f_r`:
//!
//! ```text
//! FTF  = f_r / 2 · (1 − d/D · cos φ)                 cage (fundamental train)
//! BPFO = n · f_r / 2 · (1 − d/D · cos φ)             ball pass, outer race
//! BPFI = n · f_r / 2 · (1 + d/D · cos φ)             ball pass, inner race
//! BSF  = D · f_r / (2d) · (1 − (d/D · cos φ)²)       ball spin
//! ```
//!
//! The paper (§5.2) leaves these "in textual form"; they are the standard
//! kinematic relations (no slip). Real bearings slip 1–2 %, which the closed loop
//! (`slip` effect) accounts for, not this module.

use crate::error::{Error, Result};
use crate::math;

/// Geometry of a rolling-element bearing. Lengths in any one unit (ratios only are used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingGeometry {
    /// Number of rolling elements `n`.
    pub n_elements: u8,
    /// Rolling-element diameter `d`.
    pub element_diameter: f32,
    /// Pitch diameter `D`.
    pub pitch_diameter: f32,
    /// Contact angle `φ` in degrees.
    pub contact_angle_deg: f32,
}

/// Defect frequencies as multiples of the shaft rate (orders).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefectOrders {
    /// Fundamental train (cage) frequency / shaft rate.
    pub ftf: f32,
    /// Ball pass frequency, outer race / shaft rate.
    pub bpfo: f32,
    /// Ball pass frequency, inner race / shaft rate.
    pub bpfi: f32,
    /// Ball spin frequency / shaft rate.
    pub bsf: f32,
}

/// Defect frequencies in hertz at a given shaft rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefectFrequencies {
    /// Shaft rate `f_r` in Hz.
    pub shaft: f32,
    /// Cage frequency in Hz.
    pub ftf: f32,
    /// Outer-race ball pass frequency in Hz.
    pub bpfo: f32,
    /// Inner-race ball pass frequency in Hz.
    pub bpfi: f32,
    /// Ball spin frequency in Hz.
    pub bsf: f32,
}

/// Which part of the bearing carries a localized defect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DefectLocation {
    /// Outer race: impacts at BPFO, fixed load zone.
    OuterRace,
    /// Inner race: impacts at BPFI, modulated at the shaft rate.
    InnerRace,
    /// Rolling element: impacts at 2·BSF (the ball strikes both races), modulated at FTF.
    Ball,
}

impl BearingGeometry {
    /// SKF 6205-2RS JEM, the CWRU drive-end bearing (inches).
    pub const CWRU_6205_DE: Self = Self {
        n_elements: 9,
        element_diameter: 0.3126,
        pitch_diameter: 1.537,
        contact_angle_deg: 0.0,
    };
    /// SKF 6203-2RS JEM, the CWRU fan-end bearing (inches).
    pub const CWRU_6203_FE: Self = Self {
        n_elements: 8,
        element_diameter: 0.2656,
        pitch_diameter: 1.122,
        contact_angle_deg: 0.0,
    };

    /// A custom geometry, checked: `n ≥ 3`, `0 < d < D`, `0 ≤ φ < 90°`.
    pub fn new(n: u8, d: f32, pitch: f32, contact_angle_deg: f32) -> Result<Self> {
        let g = Self {
            n_elements: n,
            element_diameter: d,
            pitch_diameter: pitch,
            contact_angle_deg,
        };
        g.validate()?;
        Ok(g)
    }

    /// Check the geometry is physically possible.
    pub fn validate(&self) -> Result<()> {
        let finite = self.element_diameter.is_finite()
            && self.pitch_diameter.is_finite()
            && self.contact_angle_deg.is_finite();
        if !finite {
            return Err(Error::NonFinite);
        }
        if self.n_elements < 3 {
            return Err(Error::InvalidParameter(
                "bearing needs at least 3 rolling elements",
            ));
        }
        if !(self.element_diameter > 0.0 && self.element_diameter < self.pitch_diameter) {
            return Err(Error::InvalidParameter(
                "need 0 < element diameter < pitch diameter",
            ));
        }
        if !(0.0..90.0).contains(&self.contact_angle_deg) {
            return Err(Error::InvalidParameter(
                "contact angle must be in [0, 90) degrees",
            ));
        }
        Ok(())
    }

    /// Defect frequencies as orders of the shaft rate (computed in f64).
    pub fn orders(&self) -> DefectOrders {
        let n = f64::from(self.n_elements);
        let ratio = f64::from(self.element_diameter) / f64::from(self.pitch_diameter)
            * math::cos(f64::from(self.contact_angle_deg) * math::PI / 180.0);
        let ftf = 0.5 * (1.0 - ratio);
        DefectOrders {
            ftf: ftf as f32,
            bpfo: (n * ftf) as f32,
            bpfi: (0.5 * n * (1.0 + ratio)) as f32,
            bsf: (f64::from(self.pitch_diameter) / (2.0 * f64::from(self.element_diameter))
                * (1.0 - ratio * ratio)) as f32,
        }
    }

    /// Defect frequencies in Hz at shaft rate `shaft_hz`.
    pub fn frequencies(&self, shaft_hz: f32) -> DefectFrequencies {
        let o = self.orders();
        DefectFrequencies {
            shaft: shaft_hz,
            ftf: o.ftf * shaft_hz,
            bpfo: o.bpfo * shaft_hz,
            bpfi: o.bpfi * shaft_hz,
            bsf: o.bsf * shaft_hz,
        }
    }
}

impl DefectFrequencies {
    /// Impact rate in Hz for a defect at `location` (eq. 18: `1 / T_impact`).
    ///
    /// A ball defect strikes the inner and the outer race once per spin revolution
    /// each, so its impact rate is `2·BSF`.
    pub fn impact_rate(&self, location: DefectLocation) -> f32 {
        match location {
            DefectLocation::OuterRace => self.bpfo,
            DefectLocation::InnerRace => self.bpfi,
            DefectLocation::Ball => 2.0 * self.bsf,
        }
    }
    /// Frequency of the amplitude modulation that a rotating load zone puts on the
    /// impacts: shaft rate for an inner-race defect, cage rate for a ball, none (0)
    /// for a stationary outer-race defect.
    pub fn modulation_rate(&self, location: DefectLocation) -> f32 {
        match location {
            DefectLocation::OuterRace => 0.0,
            DefectLocation::InnerRace => self.shaft,
            DefectLocation::Ball => self.ftf,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published CWRU multipliers (bearing data center, "bearing information" page).
    #[test]
    fn cwru_6205_orders_match_published() {
        let o = BearingGeometry::CWRU_6205_DE.orders();
        assert!((o.bpfi - 5.4152).abs() < 5e-4, "bpfi {}", o.bpfi);
        assert!((o.bpfo - 3.5848).abs() < 5e-4, "bpfo {}", o.bpfo);
        assert!((o.ftf - 0.39828).abs() < 5e-4, "ftf {}", o.ftf);
        assert!((o.bsf - 2.357).abs() < 1e-3, "bsf {}", o.bsf);
    }

    #[test]
    fn cwru_6203_orders_match_published() {
        let o = BearingGeometry::CWRU_6203_FE.orders();
        assert!((o.bpfi - 4.9469).abs() < 5e-4, "bpfi {}", o.bpfi);
        assert!((o.bpfo - 3.0530).abs() < 5e-4, "bpfo {}", o.bpfo);
        assert!((o.ftf - 0.3817).abs() < 5e-4, "ftf {}", o.ftf);
        assert!((o.bsf - 1.9944).abs() < 1e-3, "bsf {}", o.bsf);
    }

    #[test]
    fn bpfo_plus_bpfi_is_n_times_shaft() {
        let g = BearingGeometry::new(11, 7.9, 39.0, 15.0).unwrap();
        let f = g.frequencies(25.0);
        assert!((f.bpfo + f.bpfi - 11.0 * 25.0).abs() < 1e-3);
        assert!((f.bpfo - 11.0 * f.ftf).abs() < 1e-3);
    }

    #[test]
    fn rejects_impossible_geometry() {
        assert!(BearingGeometry::new(2, 1.0, 5.0, 0.0).is_err());
        assert!(BearingGeometry::new(9, 5.0, 5.0, 0.0).is_err());
        assert!(BearingGeometry::new(9, 1.0, 5.0, 90.0).is_err());
        assert_eq!(
            BearingGeometry::new(9, f32::NAN, 5.0, 0.0),
            Err(Error::NonFinite)
        );
    }
}
