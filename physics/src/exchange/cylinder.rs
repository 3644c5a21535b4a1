//! Drag on a dispersed field of circular cylinders (2D particles) of diameter d, per unit
//! length.
//!
//! The FIRST field of `between` is the fluid (ρ_f, θ_f), the second the particles. With
//! Re = ρ_f |Δu| d / μ, Δu = u_f − u_s the (interstitial) face slip, and C_D defined on
//! the projected length d (F = ½ ρ_f C_D d |Δu| Δu per unit length):
//!
//! - Re ≤ 0.5, Lamb (1911), *Phil. Mag.* 21, 112 (Oseen's equations):
//!   F = 4π μ Δu / (½ − γ − ln(Re/8)), γ = 0.5772… (Euler's constant), i.e.
//!   C_D Re = 8π / (½ − γ − ln(Re/8)). The denominator vanishes at Re = 8e^(½−γ) ≈ 7.41,
//!   so the law is used only well below that.
//! - Re ≥ 1, White (1991), *Viscous Fluid Flow*, 2nd ed., eq. (3-225), a fit to the data
//!   for 1 ≤ Re ≤ 2×10⁵: C_D ≈ 1 + 10 Re^(−2/3), i.e. C_D Re = Re + 10 Re^(1/3). It is
//!   used as is above 2×10⁵ (no drag crisis).
//! - 0.5 < Re < 1: the two C_D Re are blended with the weight w = 3s² − 2s³,
//!   s = log₂(Re/0.5), so C_D and its slope in ln Re are continuous at both ends (the two
//!   laws do not cross: Lamb gives C_D = 18.65 at Re = 0.5 and 12.55 at Re = 1 where
//!   White gives 16.87 and 11.0).
//!
//! The particle volume per unit length is πd²/4, so (derivation in [`super::drag`],
//! K = F/(V_p θ_f |Δu|))
//!
//! ```text
//!     K = (2/π) C_D Re μ / (d² θ_f);   Lamb: K = 16 μ / (d² θ_f (½ − γ − ln(Re/8)))
//! ```
//!
//! As Re → 0 Lamb's K → 0 like 1/ln(1/Re) (Stokes' paradox): Re is floored at 10⁻¹²,
//! where K = 16μ/(d²θ_f · 29.63), so the coefficient at zero slip is small but not zero.
//!
//! With `di_felice: true` Di Felice's (1994) dense-suspension correction (a sphere
//! correlation, applied here by analogy) uses the superficial slip θ_f |Δu|
//! (Re_s = θ_f Re) and multiplies by θ_f^(−χ(Re_s)), χ = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re_s)²/2):
//! K = (2/π) C_D(Re_s) Re_s μ θ_f^(−χ) / d². It equals the plain law at θ_f = 1.

use super::drag::{Drag, DragCorrelation, Shape};
use multifield_core::math::Real;

/// Euler's constant γ.
pub const EULER_GAMMA: Real = 0.577_215_664_901_532_9;
/// Below this Re, Lamb's law alone.
pub const RE_LAMB: Real = 0.5;
/// Above this Re, White's fit alone.
pub const RE_WHITE: Real = 1.0;

/// C_D·Re of Lamb's law (valid for Re ≪ 1).
pub fn cd_re_lamb(re: Real) -> Real {
    8.0 * std::f64::consts::PI / (0.5 - EULER_GAMMA - (re / 8.0).ln())
}

/// C_D·Re of White's fit C_D = 1 + 10 Re^(−2/3).
pub fn cd_re_white(re: Real) -> Real {
    re + 10.0 * re.cbrt()
}

/// C_D·Re of the blended law.
pub fn cd_re(re: Real) -> Real {
    if re <= RE_LAMB {
        cd_re_lamb(re)
    } else if re >= RE_WHITE {
        cd_re_white(re)
    } else {
        let s = (re / RE_LAMB).ln() / (RE_WHITE / RE_LAMB).ln();
        let w = s * s * (3.0 - 2.0 * s);
        (1.0 - w) * cd_re_lamb(re) + w * cd_re_white(re)
    }
}

/// Drag on circular cylinders: Lamb, blended into White's fit.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cylinder;

impl DragCorrelation for Cylinder {
    const NAME: &'static str = "cylinder";
    const SUMMARY: &'static str =
        "drag on 2D cylinders (fluid = first field): Lamb below Re 0.5, White CD = 1 + 10Re^(-2/3) above 1";
    const CITATION: &'static str = "Lamb (1911), Phil. Mag. 21, 112; White (1991), Viscous Fluid Flow, 2nd ed., \
                                    eq. (3-225)";
    const SHAPE: Shape = Shape::Cylinder;
    const VALID_RE: (Real, Real) = (0.0, 2e5);
    fn cd_re(re: Real, _theta_f: Real) -> Real {
        cd_re(re)
    }
}

multifield_core::register!(Exchange, "cylinder", Drag<Cylinder>, Cylinder::SUMMARY, Drag::<Cylinder>::PARAMS);

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn law(di_felice: bool) -> Drag<Cylinder> {
        Drag { di_felice, ..Drag::new(0.1, 0.01) }
    }

    #[test]
    fn hand_computed_values() {
        // ρ_f = 1, d = 0.1, μ = 0.01: Re = 10 |Δu|, μ/d² = 1
        let m = law(false);
        // Re = 0.1, Lamb: ½ − γ − ln(0.0125) = 4.304811, F = 4πμU/4.304811 per length,
        // K = F/(πd²/4 · θ_f · U) = 16/(4.304811 θ_f)
        let k = m.coefficient(0.01, 1.0, 0.9);
        assert!((k - 16.0 / (4.304_811 * 0.9)).abs() < 1e-5, "{k}");
        // C_D(0.1) = 8π/(0.1 · 4.304811) = 58.383
        assert!((cd_re(0.1) / 0.1 - 58.383).abs() < 1e-3);
        // Re = 10, White: C_D = 1 + 10·10^(−2/3) = 3.15443, K = (2/π) C_D Re = 20.081755
        let k = m.coefficient(1.0, 1.0, 1.0);
        assert!((k - 2.0 / PI * 3.154_435 * 10.0).abs() < 1e-5, "{k}");
        assert!((k - 20.081_755).abs() < 1e-5, "{k}");
        // Re = 1000: C_D = 1.1
        assert!((cd_re(1000.0) / 1000.0 - 1.1).abs() < 1e-12);
        // zero slip: Re floored at 1e-12, K = 16/(½ − γ − ln(1.25e-13)) = 16/29.633
        let k0 = m.coefficient(0.0, 1.0, 1.0);
        assert!(k0 > 0.0 && (k0 - 16.0 / 29.633_25).abs() < 1e-4, "{k0}");
    }

    #[test]
    fn lamb_denominator_vanishes_near_re_7_4() {
        let re0 = 8.0 * (0.5 - EULER_GAMMA).exp();
        assert!((re0 - 7.4055).abs() < 1e-3, "{re0}");
        assert!(cd_re_lamb(re0 * 0.999) > 1e3);
    }

    #[test]
    fn blend_is_continuous_at_both_ends() {
        for (re, pure) in [(RE_LAMB, cd_re_lamb as fn(Real) -> Real), (RE_WHITE, cd_re_white)] {
            let (lo, hi) = (cd_re(re * (1.0 - 1e-10)), cd_re(re * (1.0 + 1e-10)));
            let jump = ((hi - lo) / lo).abs();
            assert!(jump < 1e-9, "jump at Re {re}: {jump:e}");
            assert!((cd_re(re) - pure(re)).abs() < 1e-12 * pure(re));
        }
        // monotone C_D·Re (drag grows with slip) through the blend
        let mut prev = cd_re(0.4);
        for i in 1..=100 {
            let re = 0.4 + 0.7 * i as Real / 100.0;
            let g = cd_re(re);
            assert!(g > prev, "C_D·Re not increasing at Re {re}");
            prev = g;
        }
    }

    #[test]
    fn di_felice_is_neutral_at_theta_one() {
        for slip in [0.0, 0.01, 0.07, 1.0, 1e3] {
            let (a, b) = (law(false).coefficient(slip, 1.0, 1.0), law(true).coefficient(slip, 1.0, 1.0));
            assert!((a - b).abs() <= 1e-14 * a, "slip {slip}: {a} vs {b}");
        }
        // θ_f = 0.5, Re = 20 → Re_s = 10: χ = 3.7 − 0.65 e^(−0.125)
        let k = law(true).coefficient(2.0, 1.0, 0.5);
        let chi = 3.7 - 0.65 * (-0.125f64).exp();
        let by_hand = 2.0 / PI * (10.0 + 10.0 * 10f64.cbrt()) * 0.5f64.powf(-chi);
        assert!((k - by_hand).abs() < 1e-10 * by_hand);
    }

    #[test]
    fn validation_rejects_non_positive_inputs() {
        assert!(Drag::<Cylinder>::new(0.0, 1.0).validate().is_err());
        assert!(Drag::<Cylinder> { di_felice: true, ..Drag::new(1.0, -1.0) }.validate().is_err());
    }
}
